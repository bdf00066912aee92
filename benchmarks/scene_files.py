"""The generalisation benchmark's scenes (``scenes.py``) as sinogram files, simulated analytically.

Exact line integrals (closed-form ellipse chords, each view at its own time, a few sub-rays per
detector bin), Poisson noise, supersampled truth frames, written in the documented ``.npz``
format, lengths in the scene's own units. Imports nothing from ``nct``: the files are a user's.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from scenes import Pose, Scene  # noqa: E402

MU_PER_INTENSITY_CM, FOV_SIDE_CM = 0.2, 25.0  # noise scale: intensity 1 ~ 0.2 /cm on a 25 cm FOV
SUPERSAMPLE, SUB_RAYS = 4, 4


def chord_lengths(pose: Pose, angles: np.ndarray, s: np.ndarray) -> np.ndarray:
    """Length of the chord that the ray at angle ``angles`` [V] and offset ``s`` [V, R] cuts through an
    ellipse whose pose is given per view ([V] arrays): [V, R].

    With θ' = θ − angle and h² = (a cos θ')² + (b sin θ')² (the ellipse's half-width seen along
    s = x cos θ + y sin θ), the chord at offset s' from the centre's projection is
    2ab·sqrt(h² − s'²)/h², zero beyond h.
    """
    rel = angles - pose.angle
    h2 = (pose.a * np.cos(rel)) ** 2 + (pose.b * np.sin(rel)) ** 2
    offset = s - (pose.cx * np.cos(angles) + pose.cy * np.sin(angles))[:, None]
    inside = np.clip(h2[:, None] - offset**2, 0.0, None)
    return 2 * (pose.a * pose.b / h2)[:, None] * np.sqrt(inside)


def chord_midpoints(pose: Pose, angles: np.ndarray, s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Where the middle of each chord of `chord_lengths` lies, relative to the ellipse's centre: (x, y),
    [V, R] each (meaningless where the ray misses).

    The ray is s e + t d, e = (cos θ, sin θ), d = (−sin θ, cos θ); at offset s' from the centre's
    projection, the chord's middle is s' e + t_m d where t_m minimises the ellipse's norm of
    s' e + t d: with θ' = θ − angle, t_m = s' sin θ' cos θ' (1/a² − 1/b²) / (sin² θ'/a² + cos² θ'/b²).
    """
    rel = angles - pose.angle
    sin, cos = np.sin(rel), np.cos(rel)
    inv_a2, inv_b2 = 1 / pose.a**2, 1 / pose.b**2
    along = (sin * cos * (inv_a2 - inv_b2) / (sin**2 * inv_a2 + cos**2 * inv_b2))[:, None]
    offset = s - (pose.cx * np.cos(angles) + pose.cy * np.sin(angles))[:, None]
    t_m = offset * along
    return (offset * np.cos(angles)[:, None] - t_m * np.sin(angles)[:, None],
            offset * np.sin(angles)[:, None] + t_m * np.cos(angles)[:, None])


def detector(scene: Scene, size: int) -> tuple[int, float]:
    """(n_bins, bin_spacing) in unit FOV: the truth's pixel pitch, wide enough for ``detector_width``."""
    return int(math.ceil(size * scene.acquisition.detector_width)), 1.0 / size


def line_integrals(scene: Scene, size: int) -> np.ndarray:
    """Exact line integrals of ``scene`` (unit FOV), each view at its own time, each bin the mean of
    ``SUB_RAYS`` rays spread over its width (a graded object's chord: its length × the intensity at its
    middle, exact for a linear intensity): [V, n_bins] float64."""
    acq = scene.acquisition
    n_bins, spacing = detector(scene, size)
    angles, times = acq.angles(), acq.times()
    centres = (np.arange(n_bins) - (n_bins - 1) / 2) * spacing
    sub = ((np.arange(SUB_RAYS) + 0.5) / SUB_RAYS - 0.5) * spacing
    s = np.broadcast_to((centres[:, None] + sub[None, :]).ravel(), (angles.size, n_bins * SUB_RAYS))
    total = np.zeros((angles.size, n_bins * SUB_RAYS))
    for i, obj in enumerate(scene.objects):
        pose = Pose.of(scene, i, times)
        chords = chord_lengths(pose, angles, s)
        total += obj.intensity * chords
        if obj.gradient != (0.0, 0.0):  # linear in x, y: a chord's integral is its length × its middle's value
            mx, my = chord_midpoints(pose, angles, s)
            total += (obj.gradient[0] * mx + obj.gradient[1] * my) * chords
    return total.reshape(angles.size, n_bins, SUB_RAYS).mean(axis=2)


def attenuation_scale(extent: float) -> float:
    """k with exp(−p·k) the transmitted fraction of a file line integral p: intensity 1 is taken as
    0.2 /cm on a 25 cm field of view whatever the file's unit, so that the same scene gets the same
    noise in every unit system (the project's convention, nct.scenes.simulate)."""
    return MU_PER_INTENSITY_CM * FOV_SIDE_CM / extent


def add_noise(values: np.ndarray, noise_i0: float, extent: float, rng: np.random.Generator) -> np.ndarray:
    """Measured line integrals from Poisson counts ~ I0·exp(−p·k); a ray with no photon counts one."""
    k = attenuation_scale(extent)
    counts = rng.poisson(noise_i0 * np.exp(-values * k))
    return -np.log(np.maximum(counts, 1) / noise_i0) / k


def truth_times(scene: Scene, frames_per_rotation: int) -> np.ndarray:
    """Times of the truth frames, s: ``frames_per_rotation`` per rotation, at the centres of equal
    slices of the acquisition: [F]."""
    acq = scene.acquisition
    n = frames_per_rotation * acq.rotations
    return acq.time_offset + (np.arange(n) + 0.5) * acq.duration / n


def rasterise(scene: Scene, times: np.ndarray, size: int) -> np.ndarray:
    """Truth frames at ``times`` on a ``size``² grid (unit FOV): intensities of overlapping objects add
    (a graded object's at each sub-pixel's centre),
    each pixel the mean of ``SUPERSAMPLE``² sub-pixels. Columns run along x, rows down y (y up, as
    the file format says): [F, size, size] float32."""
    fine = size * SUPERSAMPLE
    c = (np.arange(fine) + 0.5) / fine - 0.5
    x, y = np.meshgrid(c, c[::-1])
    frames = np.zeros((times.size, fine, fine))
    for i, obj in enumerate(scene.objects):
        p = Pose.of(scene, i, times)
        for f in range(times.size):
            dx, dy = x - p.cx[f], y - p.cy[f]
            u = dx * np.cos(p.angle[f]) + dy * np.sin(p.angle[f])
            v = -dx * np.sin(p.angle[f]) + dy * np.cos(p.angle[f])
            inside = (u / p.a[f]) ** 2 + (v / p.b[f]) ** 2 <= 1
            value = obj.intensity + obj.gradient[0] * dx + obj.gradient[1] * dy
            frames[f] += np.where(inside, value, 0.0)
    return frames.reshape(times.size, size, SUPERSAMPLE, size, SUPERSAMPLE).mean(axis=(2, 4)).astype(np.float32)


def write_scene(scene: Scene, path: Path, size: int, frames_per_rotation: int, seed: int,
                level: float | None = None) -> Path:
    """Simulate ``scene`` and write it in the documented sinogram format, lengths in its own units:
    sinogram [V, B] float32, angles, times, bin_spacing, truth [F, size, size], truth_times,
    truth_extent, truth_level (``level``; None: half the faintest object's intensity). ``seed`` drives
    the noise."""
    values = line_integrals(scene, size) * scene.extent
    if scene.noise_i0 is not None:
        values = add_noise(values, scene.noise_i0, scene.extent, np.random.default_rng([seed, scene.index, 1]))
    times = truth_times(scene, frames_per_rotation)
    _, spacing = detector(scene, size)
    path.parent.mkdir(parents=True, exist_ok=True)
    np.savez_compressed(path, sinogram=values.astype(np.float32), angles=scene.acquisition.angles(),
                        times=scene.acquisition.times(), bin_spacing=np.float64(spacing * scene.extent),
                        truth=rasterise(scene, times, size), truth_times=times,
                        truth_extent=np.float64(scene.extent),
                        truth_level=np.float64(0.5 * min(o.intensity for o in scene.objects) if level is None
                                               else level))
    return path
