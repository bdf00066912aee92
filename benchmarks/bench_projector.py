"""Time the projector's hot paths on CPU: training-batch forward+backward and FBP frames.

Run: python benchmarks/bench_projector.py
"""

from __future__ import annotations

import math
import time

import numpy as np
import torch

from nct.acquisition.scanner import ImageGrid, Scanner
from nct.acquisition.sinogram import Sinogram
from nct.physics.fbp import fbp_frames
from nct.physics.projector import forward_project


def best_of(fn, repeats: int = 5) -> float:
    """Best wall time of ``repeats`` calls after one warm-up, in ms."""
    fn()
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    return 1000 * min(times)


def bench_training_batch(views: int = 20, size: int = 256, n_bins: int = 128) -> None:
    images = torch.rand(views, size, size, requires_grad=True)
    angles = torch.rand(views) * 2 * math.pi
    target = torch.rand(views, n_bins)

    def step() -> None:
        loss = (forward_project(images, angles, 1.0, n_bins, 1.0 / n_bins) - target).square().mean()
        loss.backward()

    ms = best_of(step)
    print(f"forward+backward {views} views {size}x{size} -> {n_bins} bins: {ms:.1f} ms")


def bench_fbp_frames(views_per_rotation: int, rotations: float, size: int, frames: int) -> None:
    scanner = Scanner(views_per_rotation, rotations, n_bins=size, bin_spacing=1.0 / size)
    rng = np.random.default_rng(0)
    sino = Sinogram(
        values=rng.random((scanner.n_views, scanner.n_bins), dtype=np.float32),
        angles=scanner.angles,
        times=scanner.times,
        geometry=scanner.geometry,
    )
    times = np.linspace(0, scanner.duration, frames)
    ms = best_of(lambda: fbp_frames(sino, ImageGrid(size), times), repeats=2)
    print(f"fbp_frames {scanner.n_views} views {size}x{size} {frames} frames: {ms:.0f} ms")


if __name__ == "__main__":
    print(f"torch {torch.__version__}, {torch.get_num_threads()} threads")
    bench_training_batch()
    for frames in (36, 720):
        bench_fbp_frames(720, 1, 128, frames)
    bench_fbp_frames(720, 4, 256, 720)
