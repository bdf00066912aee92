"""Settings of the run wing, one dataclass per config group, each the Hydra schema of its options: what
is reconstructed (``data``: a simulation or a file; ``scanner``, ``image``), what a run writes
(``logger``, ``export``) and when it warns (``suspect``). Plain dataclasses without torch, so that
parsing a config (``schema.py``, ``config.py``) stays cheap.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from omegaconf import MISSING

from nct.acquisition.geometry import FanGeometry
from nct.acquisition.scan import FRAMES_PER_ROTATION, SIZE
from nct.acquisition.scanner import ImageGrid, Scanner
from nct.acquisition.times import TIMES_UNITS
from nct.errors import require
from nct.fit.conf import LOGGERS


def check_n_objects(value: Any) -> None:
    """``data.n_objects`` is "auto" or a whole number >= 1 (an override gives an int, a YAML "auto" a str)."""
    if value != "auto" and not (isinstance(value, int) and not isinstance(value, bool) and value >= 1):
        raise ValueError(f"data.n_objects must be auto or a whole number >= 1, got {value!r}")


def chosen_objects(value: Any) -> int | None:
    """The K a user set (``data.n_objects``), None where it is left to the data ("auto")."""
    return None if value == "auto" else int(value)


@dataclass
class SimulateConf:
    """Simulated acquisition of ``phantom``; ``noise_i0``: incident photons per ray (None: noiseless);
    ``n_objects``: K, the objects of distinct intensity to fit ("auto": chosen from the data, never read off
    the phantom; over a background, K counts the moving parts)."""

    name: str = "simulate"
    noise_i0: float | None = None
    n_objects: Any = "auto"

    def __post_init__(self) -> None:
        if self.noise_i0 is not None and not self.noise_i0 > 0:
            raise ValueError(f"data.noise_i0 must be > 0 (or null for no noise), got {self.noise_i0}")
        check_n_objects(self.n_objects)


@dataclass
class FileConf:
    """A sinogram file in the documented ``.npz`` format, or a TIFF stack whose other keys are in the
    ``sidecar`` ``.npz`` (null: the TIFF's path ending ``.npz``); ``n_objects``: K, the objects of distinct
    intensity to fit ("auto": chosen from the data; over a background, K counts the moving parts).
    ``extent``: side of the reconstructed field of view in the file's length unit when the file
    has no truth (null: the diameter every view covers); with a truth, its grid.
    ``i0``: incident counts per ray behind the values' Poisson noise, for ``loss.data_term=poisson``
    (null: the file's own ``i0``, from its key or its flat field, else estimated from the data).
    ``times_unit``: the unit of the file's times, s or ms (null: seconds, and a gantry turn slower than a
    minute is warned of, as times in ms read as s look: `nct.acquisition.times`)."""

    name: str = "file"
    path: str = MISSING
    sidecar: str | None = None
    n_objects: Any = "auto"
    extent: float | None = None
    i0: float | None = None
    times_unit: str | None = None

    def __post_init__(self) -> None:
        if self.times_unit is not None and self.times_unit not in TIMES_UNITS:
            raise ValueError(f"data.times_unit must be one of {', '.join(TIMES_UNITS)} (or null: seconds, checked), "
                             f"got '{self.times_unit}'")
        check_n_objects(self.n_objects)
        if self.extent is not None and not self.extent > 0:
            raise ValueError(f"data.extent must be > 0 (or null for the detector's width), got {self.extent}")
        if self.i0 is not None and not (self.i0 > 0 and math.isfinite(self.i0)):
            raise ValueError(f"data.i0 must be a finite number > 0 (or null: the file's, else estimated), got {self.i0}")


@dataclass
class ScannerConf:
    """Parallel-beam acquisition; ``bin_spacing`` null means image.extent / n_bins; ``detector_offset``
    shifts the detector along itself (``geometry.py``)."""

    name: str = "parallel"
    views_per_rotation: int = 720
    rotations: float = 1.0
    rotation_time: float = 0.25
    start_deg: float = 0.0
    n_bins: int = 128
    bin_spacing: float | None = None
    detector_offset: float = 0.0

    def build(self, extent: float) -> Scanner:
        """The scanner of a field of view ``extent`` a side (``ValueError`` naming the key of a bad value)."""
        spacing = extent / self.n_bins if self.bin_spacing is None else self.bin_spacing
        return Scanner(self.views_per_rotation, self.rotations, self.rotation_time, math.radians(self.start_deg),
                       self.n_bins, spacing, detector_offset=self.detector_offset)


@dataclass
class FanScannerConf(ScannerConf):
    """Fan-beam acquisition (``geometry.FanGeometry``): the source ``source_distance`` from the axis, the
    detector (``detector_shape`` flat or curved) ``detector_distance`` beyond it; ``bin_spacing`` null
    means the n_bins bins just span the fan through the field of view's inscribed disc."""

    name: str = "fan"
    source_distance: float = 2.0
    detector_distance: float = 2.0
    detector_shape: str = "flat"

    def build(self, extent: float) -> Scanner:
        half_diagonal = extent / math.sqrt(2)
        require(self.source_distance > half_diagonal, "scanner.source_distance",
                f"> image.extent / sqrt(2) = {half_diagonal:.4g} (the source outside the image)", self.source_distance)
        spacing = self.bin_spacing
        if spacing is None:
            try:
                spacing = FanGeometry.covering(extent / 2, self.n_bins, self.source_distance, self.detector_distance,
                                               self.detector_shape).bin_spacing
            except ValueError as err:
                raise ValueError(f"scanner.{err}") from None
        return Scanner(self.views_per_rotation, self.rotations, self.rotation_time, math.radians(self.start_deg),
                       self.n_bins, spacing, self.source_distance, self.detector_distance, self.detector_shape,
                       self.detector_offset)


@dataclass
class ImageConf:
    """Reconstruction grid (``size`` pixels a side over ``extent``) and output frames per rotation."""

    size: int = SIZE
    extent: float = 1.0
    frames_per_rotation: int = FRAMES_PER_ROTATION

    def __post_init__(self) -> None:
        ImageGrid(self.size, self.extent)
        if self.frames_per_rotation < 1:
            raise ValueError(f"image.frames_per_rotation must be >= 1, got {self.frames_per_rotation}")

    def build(self) -> ImageGrid:
        return ImageGrid(self.size, self.extent)


@dataclass
class LoggerConf:
    """Training logger: tensorboard, csv or none."""

    name: str = "tensorboard"

    def __post_init__(self) -> None:
        if self.name not in LOGGERS:
            raise ValueError(f"logger.name must be one of {', '.join(LOGGERS)}, got '{self.name}'")


@dataclass
class ExportConf:
    """What a run writes besides metrics: TIFF stacks, PNG strip, GIF movie (``fps`` frames/s)."""

    tiff: bool = True
    png: bool = True
    gif: bool = True
    fps: float = 8.0
    strip_frames: int = 8

    def __post_init__(self) -> None:
        if not self.fps > 0:
            raise ValueError(f"export.fps must be > 0, got {self.fps}")
        if self.strip_frames < 1:
            raise ValueError(f"export.strip_frames must be >= 1, got {self.strip_frames}")


@dataclass
class SuspectConf:
    """When ``nct.run.suspect`` warns that a fit is poor, from the held-out views' misfits beyond
    the noise's (config group ``suspect``; the measured separation is in conf/suspect/default.yaml).
    ``fbp_ratio``: the fit's misfit above this × FBP's (the race's own limit, below it, is
    ``motion.fbp_ratio``); ``excess``: the fit's misfit above this
    share of the views' mean |value|; ``offset_bins``: the detector offset the views' first moments
    call for (`nct.run.consistency`) above this many bins, when their centroid moves less than
    ``offset_motion_bins`` (RMS, bins) about a still object's; ``fan_radii``, ``fan_sigmas``: a
    parallel-beam file whose view totals swing like a fan beam's with the source to detector within
    this many field radii, the swing more than this many standard errors clear of none."""

    fbp_ratio: float = 1.25
    excess: float = 0.1
    offset_bins: float = 1.0
    offset_motion_bins: float = 0.5
    fan_radii: float = 7.0
    fan_sigmas: float = 5.0

    def __post_init__(self) -> None:
        require(self.fbp_ratio > 0, "suspect.fbp_ratio", "> 0", self.fbp_ratio)
        require(self.excess > 0, "suspect.excess", "> 0", self.excess)
        require(self.offset_bins > 0, "suspect.offset_bins", "> 0", self.offset_bins)
        require(self.offset_motion_bins > 0, "suspect.offset_motion_bins", "> 0", self.offset_motion_bins)
        require(self.fan_radii > 1, "suspect.fan_radii", "> 1", self.fan_radii)
        require(self.fan_sigmas > 0, "suspect.fan_sigmas", "> 0", self.fan_sigmas)
