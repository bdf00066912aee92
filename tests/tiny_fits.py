"""Shared by the method tests: a tiny model and short fits, and a tiny moving-disc acquisition."""

from __future__ import annotations

import numpy as np

from nct.method.capacity import CapacityConf
from nct.method.fields import ModelConf
from nct.method.reconstruct import reconstruct
from nct.method.conf import InitConf, LossConf, OptimConf, TrainerConf
from nct.scenes.phantoms import CircleConf, ComposedConf, build_phantom
from nct.acquisition.scanner import ImageGrid, Scanner
from nct.scenes.simulate import simulate
from nct.acquisition.sinogram import Sinogram

MODEL = ModelConf(width=16, depth=2, temporal_width=16, temporal_depth=2, n_terms=8)
TRAINER = TrainerConf(accelerator="cpu", progress_bar=False)
OPTIM = OptimConf(init_steps=30, fit_steps=40, refine=False, batch_views=8, warmup_steps=5, lr_decay_every=20)
INIT = InitConf(frames_per_rotation=12)


def moving_disc(grid: ImageGrid = ImageGrid(32)) -> tuple[Sinogram, np.ndarray]:
    """A disc (radius 0.2) orbiting at 60 deg/rotation, 60 views of 32 bins, noiseless; and 6 frame times."""
    scanner = Scanner(views_per_rotation=60, rotations=1.0, rotation_time=0.25, n_bins=32, bin_spacing=1 / 32)
    phantom = build_phantom(CircleConf(radius=0.2, orbit_radius=0.15, displacement_deg=60.0), scanner.rotation_time)
    times = scanner.frame_times(6)
    return simulate(phantom, scanner, grid, times, None, np.random.default_rng(0)), times


def fit_composed(objects: list, grid: ImageGrid, optim: OptimConf, noise_i0: float | None = None,
                 capacity: CapacityConf | None = None):
    """A composed scene of ``objects`` (phantoms.EllipseConf), 120 views of 40 bins, 6 frames,
    simulated analytically and reconstructed with K = len(objects): (sinogram, times, NCTResult)."""
    scanner = Scanner(views_per_rotation=120, rotations=1.0, rotation_time=0.25, n_bins=40, bin_spacing=1 / 40)
    phantom = build_phantom(ComposedConf(objects=objects), scanner.rotation_time)
    times = scanner.frame_times(6)
    sino = simulate(phantom, scanner, grid, times, noise_i0, np.random.default_rng(0))
    result = reconstruct(sino, grid, times, MODEL, LossConf(), TRAINER, 0, log_dir=None, logger="none",
                         n_objects=len(objects), optim=optim, init=INIT, capacity=capacity)
    return sino, times, result
