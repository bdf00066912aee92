"""FBP frames with a lone object's translation undone: sharp where plain FBP frames smear."""

from __future__ import annotations

import numpy as np

from nct.acquisition.scanner import ImageGrid
from nct.method.compensate import compensated_frames
from nct.method.trajectory import centroid_projections, fit_trajectory
from nct.physics.projector import fbp_frames
from tests.conftest import circle


def _dice_with_disc(frames: np.ndarray, centres: np.ndarray, grid: ImageGrid, radius: float) -> np.ndarray:
    """Dice of each frame's half-peak mask [F] with the disc of ``radius`` at ``centres`` [F, 2]."""
    x, y = grid.xy()
    truth = np.hypot(x[None] - centres[:, 0, None, None], y[None] - centres[:, 1, None, None]) < radius
    masks = frames > 0.5 * frames.max(axis=(1, 2), keepdims=True)
    return 2 * (masks & truth).sum(axis=(1, 2)) / (masks.sum(axis=(1, 2)) + truth.sum(axis=(1, 2)))


def test_the_circle_at_200_deg_per_rotation_is_sharp_where_plain_fbp_smears_it():
    """Analytic views of the project's circle (radius 0.15) at 200 deg/rotation, 64 px: the compensated
    frames' disc at every time has Dice >= 0.92 with the truth and the true peak within 10 %;
    plain FBP frames of the same views stay below 0.85."""
    sino, centre, _ = circle(200.0, views=360, size=64)
    grid = ImageGrid(64)
    times = sino.times[[30, 120, 200, 330]]
    path = fit_trajectory(sino.angles, sino.times, centroid_projections(sino))
    sharp = compensated_frames(sino, path, grid, times, 180.0, "ramp")
    plain = fbp_frames(sino, grid, times, 180.0, "ramp")
    truth = centre[[30, 120, 200, 330]]
    assert _dice_with_disc(sharp, truth, grid, 0.15).min() >= 0.92
    assert _dice_with_disc(plain, truth, grid, 0.15).max() < 0.85
    assert np.abs(np.median(sharp[sharp > 0.5], axis=None) - 1.0) < 0.1
