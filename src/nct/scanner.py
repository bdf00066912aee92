"""Acquisition geometry: the image grid and the scanner (angle and time of every view).

Convention (that of ``skimage.transform.radon``): a point (x, y), x to the right along columns,
y up against the row index, origin at the image centre, projects at angle theta to
s = x cos(theta) + y sin(theta). Detector bin i sits at s = (i - (n_bins - 1) / 2) * bin_spacing.
Pixel j of N sits at (j + 0.5) * extent / N - extent / 2 (x for columns; y is mirrored for rows).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


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


@dataclass(frozen=True)
class Scanner:
    """A parallel-beam scanner; every view's angle and time derive from here, nowhere else.

    ``rotations`` may be fractional. ``source_distance`` is reserved for fan beam (None: parallel).
    """

    views_per_rotation: int = 720
    rotations: float = 1.0
    rotation_time: float = 0.25
    start_angle: float = 0.0
    n_bins: int = 128
    bin_spacing: float = 1.0 / 128
    source_distance: float | None = None

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
        if self.source_distance is not None:
            raise NotImplementedError("fan beam (scanner.source_distance) is not implemented yet")

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
        """Detector coordinate s of every bin centre: [n_bins] float64."""
        return (np.arange(self.n_bins) - (self.n_bins - 1) / 2) * self.bin_spacing

    def frame_times(self, frames_per_rotation: int) -> np.ndarray:
        """Evenly spaced times across the acquisition, centred in their slots: [F] float64."""
        n = max(1, int(round(frames_per_rotation * self.rotations)))
        return (np.arange(n) + 0.5) * (self.duration / n)
