"""The measured data of one acquisition, and the ground truth that may come with it."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Truth:
    """Ground-truth intensity frames for scoring.

    frames: [F, H, W] float32 intensity on a square grid of side ``extent`` (rows: y down).
    times: [F] seconds. level: the Dice threshold intensity (half the faintest object).
    """

    frames: np.ndarray
    times: np.ndarray
    extent: float
    level: float


@dataclass(frozen=True)
class Sinogram:
    """Parallel-beam line integrals of one acquisition.

    values: [n_views, n_bins] float32; angles: [n_views] radians; times: [n_views] seconds,
    non-decreasing; bin_spacing: detector pitch in the image's physical units.
    """

    values: np.ndarray
    angles: np.ndarray
    times: np.ndarray
    bin_spacing: float
    source_distance: float | None = None
    truth: Truth | None = None

    @property
    def n_views(self) -> int:
        return int(self.values.shape[0])

    @property
    def n_bins(self) -> int:
        return int(self.values.shape[1])
