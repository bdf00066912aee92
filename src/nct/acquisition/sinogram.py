"""The measured data of one acquisition, and the ground truth that may come with it."""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from nct.acquisition.geometry import FanGeometry, ParallelGeometry


@dataclass(frozen=True)
class Truth:
    """Ground-truth intensity frames for scoring.

    frames: [F, H, W] float32 intensity on a square grid of side ``extent`` (rows: y down).
    times: [F] seconds. level: the Dice threshold intensity (half the faintest object; for objects
    inside others, the lowest own level). levels: each object's own level (its container's
    intensity plus half its own: an object inside another is scored there), one per object; empty
    when unknown.
    """

    frames: np.ndarray
    times: np.ndarray
    extent: float
    level: float
    levels: tuple[float, ...] = ()


@dataclass(frozen=True)
class Sinogram:
    """Line integrals of one acquisition.

    values: [n_views, n_bins] float32; angles: [n_views] radians; times: [n_views] seconds,
    non-decreasing; geometry: the rays of every bin (its ``n_bins`` that of ``values``), lengths in
    the image's physical units. i0: the incident counts per ray behind the values, for
    the noise-aware data term (raw counts: mean flat − dark; simulations: ``data.noise_i0``; a
    file's key ``i0``); None when unknown. attenuation: k such that a value p transmits exp(−k·p)
    of them (1 for −log of normalised counts; the simulations' own scale, ``simulate.attenuation_scale``).
    """

    values: np.ndarray
    angles: np.ndarray
    times: np.ndarray
    geometry: ParallelGeometry | FanGeometry
    truth: Truth | None = None
    i0: float | None = None
    attenuation: float = 1.0

    def __post_init__(self) -> None:
        if self.geometry.n_bins != self.n_bins:
            raise ValueError(f"Sinogram: values have {self.n_bins} bins, its geometry {self.geometry.n_bins}")

    @property
    def n_views(self) -> int:
        return int(self.values.shape[0])

    @property
    def n_bins(self) -> int:
        return int(self.values.shape[1])

    def binned(self, factor: int) -> Sinogram:
        """The views with every ``factor`` adjacent bins averaged (no truth: it is what a coarser detector
        measures, for a fit): each bin ``factor`` times as wide at its bins' mean position, ``n_bins % factor``
        bins left out at the edges (half each side), the incident counts ``factor`` times a bin's."""
        keep = self.n_bins // factor * factor
        start = (self.n_bins - keep) // 2
        values = self.values[:, start:start + keep].reshape(self.n_views, -1, factor).mean(axis=-1, dtype=np.float64)
        g = self.geometry
        geometry = replace(g, n_bins=keep // factor, bin_spacing=g.bin_spacing * factor,
                           detector_offset=float(g.bin_positions[start:start + keep].mean()))
        return replace(self, values=values.astype(np.float32), geometry=geometry, truth=None,
                       i0=None if self.i0 is None else self.i0 * factor)
