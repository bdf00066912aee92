"""The measured data of one acquisition, and the ground truth that may come with it."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from nct.acquisition.geometry import FanGeometry, ParallelGeometry, make_geometry


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
    """Line integrals of one acquisition.

    values: [n_views, n_bins] float32; angles: [n_views] radians; times: [n_views] seconds,
    non-decreasing; bin_spacing: detector pitch in the image's physical units. Parallel beam
    unless ``source_distance`` is given; the detector fields are the file keys of ``io.py``, and
    `geometry` is what every consumer asks. i0: the incident counts per ray behind the values, for
    the noise-aware data term (raw counts: mean flat − dark; simulations: ``data.noise_i0``; a
    file's key ``i0``); None when unknown. attenuation: k such that a value p transmits exp(−k·p)
    of them (1 for −log of normalised counts; the simulations' own scale, ``simulate.attenuation_scale``).
    """

    values: np.ndarray
    angles: np.ndarray
    times: np.ndarray
    bin_spacing: float
    source_distance: float | None = None
    truth: Truth | None = None
    detector_distance: float | None = None
    detector_shape: str | None = None
    detector_offset: float = 0.0
    i0: float | None = None
    attenuation: float = 1.0

    @property
    def geometry(self) -> ParallelGeometry | FanGeometry:
        """The rays of every bin (raises ``ValueError`` naming the key of an invalid value)."""
        return make_geometry(self.n_bins, self.bin_spacing, self.source_distance, self.detector_distance,
                             self.detector_shape, self.detector_offset)

    @property
    def n_views(self) -> int:
        return int(self.values.shape[0])

    @property
    def n_bins(self) -> int:
        return int(self.values.shape[1])
