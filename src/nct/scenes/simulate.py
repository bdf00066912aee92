"""Simulated acquisitions: a phantom's exact projections, optional Poisson noise, ground truth.

Noise model: intensity 1.0 is taken as μ = 0.2 /cm (soft tissue / water at ~70 keV) and the field
of view's side (``grid.extent``) as 25 cm, so a line integral p (FOV units) attenuates by
exp(−p·k) with k = 0.2 · 25 / extent. Counts ~ Poisson(I0·exp(−p·k)); the measured line integral
is −log(max(counts, 1) / I0) / k (a ray that records no photon is clipped to one).
"""

from __future__ import annotations

import math

import numpy as np

from nct.acquisition.scanner import ImageGrid, Scanner
from nct.acquisition.sinogram import Sinogram, Truth
from nct.scenes.shapes import Phantom

MU_PER_INTENSITY_CM = 0.2  # linear attenuation (1/cm) of intensity 1.0
FOV_SIDE_CM = 25.0  # physical side of the field of view


def attenuation_scale(extent: float) -> float:
    """k such that exp(−p·k) is the transmitted fraction of a line integral p on a FOV of side ``extent``."""
    return MU_PER_INTENSITY_CM * FOV_SIDE_CM / extent


def add_poisson_noise(values: np.ndarray, noise_i0: float, extent: float, rng: np.random.Generator) -> np.ndarray:
    """Noisy line integrals from ``noise_i0`` incident photons per ray: [V, B] -> [V, B] float32."""
    if not (noise_i0 > 0 and math.isfinite(noise_i0)):
        raise ValueError(f"noise_i0 must be a finite number > 0 (or None for no noise), got {noise_i0}")
    k = attenuation_scale(extent)
    counts = rng.poisson(noise_i0 * np.exp(-np.asarray(values, dtype=np.float64) * k))
    return (-np.log(np.maximum(counts, 1) / noise_i0) / k).astype(np.float32)


def simulate(phantom: Phantom, scanner: Scanner, grid: ImageGrid, frame_times: np.ndarray,
             noise_i0: float | None, rng: np.random.Generator) -> Sinogram:
    """Acquire ``phantom`` with ``scanner`` (each view at its own time) and attach the truth:
    frames [F, H, W] on ``grid`` at ``frame_times`` [F] s, each object's own level (`Phantom.levels`)
    and the Dice level, the lowest of a positive object's (half the faintest object, when apart)."""
    frame_times = np.asarray(frame_times, dtype=np.float64)
    if frame_times.ndim != 1 or frame_times.size == 0 or not np.isfinite(frame_times).all():
        raise ValueError(f"frame_times must be a non-empty 1-D array of finite times, got shape {frame_times.shape}")
    values = phantom.project(scanner, grid)
    if noise_i0 is not None:
        values = add_poisson_noise(values, noise_i0, grid.extent, rng)
    levels = phantom.levels(frame_times)
    truth = Truth(frames=phantom.frames(frame_times, grid), times=frame_times, extent=grid.extent,
                  level=min(v for v, i in zip(levels, phantom.intensities) if i > 0), levels=levels)
    return Sinogram(values=values, angles=scanner.angles, times=scanner.times, geometry=scanner.geometry, truth=truth,
                    i0=noise_i0, attenuation=attenuation_scale(grid.extent))
