"""The measured data as one typed value: the sinogram, and the grid and times of the frames to reconstruct.

``Scan(sinogram, angles, times, bin_spacing=...)`` takes arrays (any real dtype, lists too) and checks
them as a sinogram file's keys are checked (`nct.acquisition.keys.parse`), each error one line naming the
argument; ``Scan.from_file`` reads a file (`nct.acquisition.io.load_sinogram`). `output_grid` is the one
place that turns a sinogram and the requested size into the output grid and frame times, whichever way
the data came (an array, a file, a simulation).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from numbers import Integral, Real
from pathlib import Path

import numpy as np

from nct.acquisition.geometry import Geometry
from nct.acquisition.io import load_sinogram
from nct.acquisition.keys import parse
from nct.acquisition.scanner import ImageGrid
from nct.acquisition.sinogram import Sinogram, Truth
from nct.acquisition.times import TIMES_UNITS
from nct.errors import InputError

SIZE = 128  # output frames' pixels a side (config image.size)
FRAMES_PER_ROTATION = 36  # output frames per gantry rotation (config image.frames_per_rotation)
SOURCE = "nct.Scan"  # what errors about a Scan's arrays name as their source


def output_grid(sino: Sinogram, size: int = SIZE, extent: float | None = None,
                frames_per_rotation: int = FRAMES_PER_ROTATION) -> tuple[ImageGrid, np.ndarray]:
    """The grid and frame times [F] (s) to reconstruct ``sino`` on: its truth's when it has one, else
    ``size`` pixels over ``extent`` (None: the diameter every view covers) and ``frames_per_rotation``
    frames a rotation, centred in equal slots from the first view to the last."""
    if sino.truth is not None:
        return ImageGrid(sino.truth.frames.shape[-1], sino.truth.extent), sino.truth.times
    _check_grid(size, extent, frames_per_rotation)
    grid = ImageGrid(size, extent if extent is not None else 2 * sino.geometry.field_radius)
    span = float(np.ptp(sino.angles)) / (2 * math.pi)
    n = max(1, round(frames_per_rotation * max(span, 1e-9)))
    edges = np.linspace(sino.times[0], sino.times[-1], n + 1)
    return grid, 0.5 * (edges[:-1] + edges[1:])


def _check_grid(size: int, extent: float | None, frames_per_rotation: int) -> None:
    """`InputError` naming the argument of a bad output size, extent or frame rate."""
    if not _whole(size) or size < 2:
        raise InputError(f"{SOURCE}: size must be a whole number >= 2 (pixels a side), got {size!r}")
    if extent is not None and not _positive(extent):
        raise InputError(f"{SOURCE}: extent must be a finite number > 0 (or None: the detector's reach), "
                         f"got {extent!r}")
    if not _whole(frames_per_rotation) or frames_per_rotation < 1:
        raise InputError(f"{SOURCE}: frames_per_rotation must be a whole number >= 1, got {frames_per_rotation!r}")


def _whole(value: object) -> bool:
    return isinstance(value, Integral) and not isinstance(value, bool)


def _positive(value: object) -> bool:
    """A finite real number > 0."""
    return isinstance(value, Real) and not isinstance(value, bool) and math.isfinite(value) and value > 0


def _check_unit(times_unit: str | None) -> None:
    if times_unit is not None and times_unit not in TIMES_UNITS:
        raise InputError(f"{SOURCE}: times_unit must be one of {', '.join(TIMES_UNITS)} (or None: seconds), "
                         f"got {times_unit!r}")


def _array(value: object, name: str) -> np.ndarray:
    """``value`` as a numpy array; a ragged or non-numeric one is refused naming ``name``."""
    try:
        return np.asarray(value)
    except (ValueError, TypeError):
        raise InputError(f"{SOURCE}: {name}: expected a numeric array, got a ragged or mixed sequence") from None


def _keys(geometry: Geometry | None, bin_spacing: float | None, n_bins: int) -> dict[str, np.ndarray]:
    """The file keys of the detector: ``bin_spacing`` (parallel beam), or those of ``geometry``."""
    if geometry is None:
        if bin_spacing is None:
            raise InputError(f"{SOURCE}: bin_spacing (the detector's bin width) or geometry is required")
        return {"bin_spacing": _array(bin_spacing, "bin_spacing")}
    if bin_spacing is not None:
        raise InputError(f"{SOURCE}: give bin_spacing or geometry, not both (the geometry holds its bin spacing)")
    if not isinstance(geometry, Geometry):
        raise InputError(f"{SOURCE}: geometry must be a ParallelGeometry or FanGeometry "
                         f"(nct.acquisition.geometry), got {type(geometry).__name__}")
    if geometry.n_bins != n_bins:
        raise InputError(f"{SOURCE}: geometry has {geometry.n_bins} bins, the sinogram {n_bins}")
    return {key: np.asarray(value) for key, value in geometry.keys().items()}


def _truth_keys(truth: Truth | None) -> dict[str, np.ndarray]:
    """The file keys of a truth (frames, times, extent, levels) to check as a file's are."""
    if truth is None:
        return {}
    if not isinstance(truth, Truth):
        raise InputError(f"{SOURCE}: truth must be an nct.Truth(frames, times, extent, level), "
                         f"got {type(truth).__name__}")
    keys = {"truth": _array(truth.frames, "truth.frames"), "truth_times": _array(truth.times, "truth.times"),
            "truth_extent": np.asarray(truth.extent), "truth_level": np.asarray(truth.level)}
    return keys | ({"truth_levels": np.asarray(truth.levels, dtype=np.float64)} if truth.levels else {})


@dataclass(frozen=True, init=False, eq=False)
class Scan:
    """One acquisition to reconstruct: ``sinogram`` (values [V, B] float32, angles [V] rad, times [V] s,
    geometry, truth or None), the output ``grid`` and ``frame_times`` [F] (s), the unit the times were
    given in (``times_unit``, None: seconds, unstated) and whether nct's own simulation made the data
    (``simulated``: its geometry and times are those that made them, so neither is checked).

    ``Scan(sinogram, angles, times, bin_spacing=...)``: ``sinogram`` [V, B] line integrals, ``angles``
    [V] radians, ``times`` [V] in ``times_unit`` (s or ms; None: seconds, a turn slower than a minute
    warned of), parallel beam of bins ``bin_spacing`` apart, or any ``geometry``
    (`nct.acquisition.geometry`); ``truth`` (an `nct.Truth`, its times in ``times_unit``) for scoring,
    ``i0`` the incident counts per ray (``loss.data_term=poisson``). Frames: ``size`` pixels a side over
    ``extent`` (None: the diameter every view covers), ``frames_per_rotation`` a rotation; with a
    truth, its grid and times (`output_grid`).
    """

    sinogram: Sinogram
    grid: ImageGrid
    frame_times: np.ndarray
    times_unit: str | None
    simulated: bool

    def __init__(self, sinogram: object, angles: object, times: object, *, bin_spacing: float | None = None,
                 geometry: Geometry | None = None, truth: Truth | None = None, i0: float | None = None,
                 times_unit: str | None = None, size: int = SIZE, extent: float | None = None,
                 frames_per_rotation: int = FRAMES_PER_ROTATION) -> None:
        _check_unit(times_unit)
        _check_grid(size, extent, frames_per_rotation)
        values = _array(sinogram, "sinogram")
        data = {"sinogram": values, "angles": _array(angles, "angles"), "times": _array(times, "times"),
                **_keys(geometry, bin_spacing, values.shape[1] if values.ndim == 2 else 0), **_truth_keys(truth)}
        if i0 is not None:
            data["i0"] = _array(i0, "i0")
        sino = parse(data, SOURCE, times_unit)
        self._hold(sino, *output_grid(sino, size, extent, frames_per_rotation), times_unit, False)

    def _hold(self, sino: Sinogram, grid: ImageGrid, frame_times: np.ndarray, times_unit: str | None,
              simulated: bool) -> None:
        for name, value in (("sinogram", sino), ("grid", grid), ("frame_times", np.asarray(frame_times)),
                            ("times_unit", times_unit), ("simulated", simulated)):
            object.__setattr__(self, name, value)

    @classmethod
    def of(cls, sino: Sinogram, grid: ImageGrid, frame_times: np.ndarray, times_unit: str | None = None,
           simulated: bool = False) -> Scan:
        """The scan of an already validated ``sino`` on ``grid`` at ``frame_times`` [F] (s), as `output_grid`
        gives them (a simulation's, a file's, a saved reconstruction's)."""
        scan = cls.__new__(cls)
        scan._hold(sino, grid, frame_times, times_unit, simulated)
        return scan

    @classmethod
    def from_file(cls, path: str | Path, sidecar: str | Path | None = None, times_unit: str | None = None, *,
                  i0: float | None = None, size: int = SIZE, extent: float | None = None,
                  frames_per_rotation: int = FRAMES_PER_ROTATION) -> Scan:
        """The scan of a sinogram file (docs/DATA.md: ``.npz``, or a TIFF stack with its ``sidecar``), its
        times in ``times_unit``; ``i0`` replaces the file's incident counts; the frames as in ``Scan``."""
        _check_unit(times_unit)
        if i0 is not None and not _positive(i0):
            raise InputError(f"{SOURCE}: i0 must be a finite number > 0 (or None: the file's), got {i0!r}")
        sino = load_sinogram(path, sidecar, times_unit)
        sino = sino if i0 is None else replace(sino, i0=float(i0))
        return cls.of(sino, *output_grid(sino, size, extent, frames_per_rotation), times_unit)

    def to_fit(self, fit_size: int | None) -> Scan:
        """The scan a fit reads: this one, or where its grid is at least twice ``fit_size`` (None: never), its
        views binned by the factor f = size // fit_size (`ImageGrid.fit_factor`) onto a grid of size // f pixels
        over the same field (`Sinogram.binned`; no truth); the frames' times the same."""
        factor = self.grid.fit_factor(fit_size, self.sinogram.n_bins)
        if factor == 1:
            return self
        return Scan.of(self.sinogram.binned(factor), ImageGrid(self.grid.size // factor, self.grid.extent),
                       self.frame_times, self.times_unit, self.simulated)

    @property
    def truth(self) -> Truth | None:
        """The true frames for scoring, when the data came with them."""
        return self.sinogram.truth

    def __repr__(self) -> str:
        s = self.sinogram
        return (f"Scan({s.n_views} views x {s.n_bins} bins, {self.grid.size}x{self.grid.size} px over "
                f"{self.grid.extent:g}, {len(self.frame_times)} frames{', with truth' if s.truth else ''})")
