"""The image grid and the scanner (angle and time of every view, and its detector's `Geometry`).

Convention (that of ``skimage.transform.radon``): a point (x, y), x to the right along columns,
y up against the row index, origin at the image centre, projects at angle theta to
s = x cos(theta) + y sin(theta) in parallel beam; rays and bins of every beam are in ``geometry.py``.
Pixel j of N sits at (j + 0.5) * extent / N - extent / 2 (x for columns; y is mirrored for rows).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from nct.acquisition.geometry import FanGeometry, ParallelGeometry, make_geometry


@dataclass(frozen=True)
class ImageGrid:
    """A square image grid: ``size`` pixels a side covering ``extent`` (physical units) a side."""

    size: int
    extent: float = 1.0

    def __post_init__(self) -> None:
        if self.size < 2:
            raise ValueError(f"ImageGrid.size must be >= 2, got {self.size}")
        if not self.extent > 0:
            raise ValueError(f"ImageGrid.extent must be > 0, got {self.extent}")

    @property
    def pixel_size(self) -> float:
        return self.extent / self.size

    @property
    def centres(self) -> np.ndarray:
        """Pixel-centre coordinates along one axis, ascending: [size]."""
        return (np.arange(self.size) + 0.5) * self.pixel_size - self.extent / 2

    def xy(self) -> tuple[np.ndarray, np.ndarray]:
        """Coordinates of every pixel centre, each [size, size] indexed [row, col]; y is up."""
        c = self.centres
        x, y = np.meshgrid(c, c[::-1])
        return x, y

    def refined(self, factor: int) -> "ImageGrid":
        """The same field of view sampled ``factor`` times finer."""
        return ImageGrid(self.size * factor, self.extent)

    def fit_factor(self, fit_size: int | None, n_bins: int) -> int:
        """The factor by which a fit of this grid at ``fit_size`` pixels (``optim.fit_size``; None: never) bins its
        ``n_bins`` detector bins and coarsens the grid: size // fit_size where that is at least 2 and the detector
        holds at least twice as many bins; else 1 (the fit reads the views as they are)."""
        factor = self.size // fit_size if fit_size else 1
        return factor if factor >= 2 and n_bins >= 2 * factor else 1


@dataclass(frozen=True)
class Scanner:
    """A scanner; every view's angle and time derive from here, nowhere else, and its rays from `geometry`.

    ``rotations`` may be fractional. Parallel beam unless ``source_distance`` is given; the fan-beam
    keys (``source_distance``, ``detector_distance``, ``detector_shape``) and ``detector_offset``
    are those of `geometry.make_geometry`.
    """

    views_per_rotation: int = 720
    rotations: float = 1.0
    rotation_time: float = 0.25
    start_angle: float = 0.0
    n_bins: int = 128
    bin_spacing: float = 1.0 / 128
    source_distance: float | None = None
    detector_distance: float | None = None
    detector_shape: str | None = None
    detector_offset: float = 0.0

    def __post_init__(self) -> None:
        if self.views_per_rotation < 2:
            raise ValueError(f"scanner.views_per_rotation must be >= 2, got {self.views_per_rotation}")
        if not self.rotations > 0:
            raise ValueError(f"scanner.rotations must be > 0, got {self.rotations}")
        if not self.rotation_time > 0:
            raise ValueError(f"scanner.rotation_time must be > 0, got {self.rotation_time}")
        if self.n_bins < 2:
            raise ValueError(f"scanner.n_bins must be >= 2, got {self.n_bins}")
        if not self.bin_spacing > 0:
            raise ValueError(f"scanner.bin_spacing must be > 0, got {self.bin_spacing}")
        try:
            self.geometry
        except ValueError as err:
            raise ValueError(f"scanner.{err}") from None

    @property
    def geometry(self) -> ParallelGeometry | FanGeometry:
        """The detector and beam of every view."""
        return make_geometry(self.n_bins, self.bin_spacing, self.source_distance, self.detector_distance,
                             self.detector_shape, self.detector_offset)

    @property
    def n_views(self) -> int:
        return int(round(self.views_per_rotation * self.rotations))

    @property
    def duration(self) -> float:
        """Acquisition time in seconds."""
        return self.rotations * self.rotation_time

    @property
    def angles(self) -> np.ndarray:
        """Gantry angle of every view in radians, increasing without wrap: [n_views] float64."""
        v = np.arange(self.n_views)
        return self.start_angle + 2 * math.pi * v / self.views_per_rotation

    @property
    def times(self) -> np.ndarray:
        """Acquisition time of every view in seconds, starting at 0: [n_views] float64."""
        return np.arange(self.n_views) * (self.rotation_time / self.views_per_rotation)

    @property
    def bin_positions(self) -> np.ndarray:
        """Detector coordinate of every bin centre: [n_bins] float64."""
        return self.geometry.bin_positions

    def frame_times(self, frames_per_rotation: int) -> np.ndarray:
        """Evenly spaced times across the acquisition, centred in their slots: [F] float64."""
        n = max(1, int(round(frames_per_rotation * self.rotations)))
        return (np.arange(n) + 0.5) * (self.duration / n)
