"""The sinogram file's keys (``io.py`` lists them) checked and turned into a `Sinogram`: `parse`, for a
file's arrays and for a `Scan`'s alike, each error one line naming the key."""

from __future__ import annotations

import logging
from dataclasses import replace

import numpy as np

from nct.acquisition.checks import array, bad_key, scalar
from nct.acquisition.counts import RAW_KEYS, line_integrals
from nct.acquisition.geometry import DETECTOR_SHAPES, Geometry, make_geometry
from nct.acquisition.sinogram import Sinogram, Truth
from nct.acquisition.times import in_seconds, seconds_per
from nct.errors import InputError

REQUIRED = ("angles", "times", "bin_spacing")  # and the data: ``sinogram``, or ``counts`` with ``flat``
DATA_KEYS = ("sinogram", "counts")
GEOMETRY_KEYS = ("source_distance", "detector_distance", "detector_shape", "detector_offset")
OPTIONAL = (*GEOMETRY_KEYS, *RAW_KEYS, "truth", "truth_times", "truth_extent", "truth_level", "truth_levels",
            "angles_unit", "i0", "attenuation")
ANGLES_UNITS = ("rad", "deg")
MAX_ROTATIONS = 16  # angles in radians spanning more turns than this look like degrees
LARGEST = 1e9  # |line integral| beyond this is no attenuation (a scaling or type error)
CAST_TOLERANCE = 1e-6  # a cast to float32 that moves a value by more than this share of the data's range warns

log = logging.getLogger(__name__)


def parse(data: dict[str, np.ndarray], path: str, times_unit: str | None = None) -> Sinogram:
    """The validated sinogram of the arrays ``data`` (a file's keys, or a `Scan`'s) from ``path`` (times: ``times_unit``)."""
    for key in REQUIRED:
        if key not in data:
            raise bad_key(path, key, "present (required keys: sinogram or counts, " + ", ".join(REQUIRED) + ")",
                          "missing")
    unknown = sorted(set(data) - set(REQUIRED) - set(DATA_KEYS) - set(OPTIONAL))
    if unknown:
        raise bad_key(path, unknown[0], "one of " + ", ".join(DATA_KEYS + REQUIRED + OPTIONAL), "an unknown key")
    data_key = "counts" if "counts" in data else "sinogram"
    _check_orientation(data, path, data_key)
    values, i0 = _values(data, path)
    if values.shape[0] < 2 or values.shape[1] < 2:
        raise bad_key(path, data_key, "shape [n_views >= 2, n_bins >= 2]", f"shape {values.shape}")
    _check_values(values, path, data_key)
    values = working_dtype(values, path, data_key)
    n_views = values.shape[0]
    angles = _angles(data, path, n_views)
    times = array(data, path, "times", 1, n_views).astype(np.float64)
    if np.any(np.diff(times) < 0):
        raise bad_key(path, "times", "non-decreasing times", "times that go backwards")
    if np.ptp(times) == 0:
        raise bad_key(path, "times", "times that advance over the scan", f"every view at the same time {times[0]:g}")
    times = in_seconds(angles, times, times_unit, path)
    geometry = _geometry(data, path, values.shape[1])
    truth = _load_truth(data, path)
    if truth is not None:
        truth = replace(truth, times=truth.times * seconds_per(times_unit))
    attenuation = scalar(data, path, "attenuation") if "attenuation" in data else 1.0
    return Sinogram(values, angles, times, geometry, truth=truth, i0=i0, attenuation=attenuation)


def _values(data: dict[str, np.ndarray], path: str) -> tuple[np.ndarray, float | None]:
    """The line integrals [n_views, n_bins] float32 and the incident intensity I0 (None if unknown)."""
    present = [key for key in DATA_KEYS if key in data]
    if len(present) != 1:
        raise bad_key(path, "sinogram", "either 'sinogram' (line integrals) or 'counts' (with 'flat' and 'dark')",
                      "both" if present else "neither")
    i0 = scalar(data, path, "i0") if "i0" in data else None
    if present == ["counts"]:
        if i0 is not None:
            raise bad_key(path, "i0", "absent with 'counts' (I0 is the mean of flat - dark)", repr(i0))
        return line_integrals(data, path)
    for key in RAW_KEYS:
        if key in data:
            raise bad_key(path, key, "only with 'counts' (raw data), not with 'sinogram'", "the key present")
    return array(data, path, "sinogram", 2), i0


def _check_orientation(data: dict[str, np.ndarray], path: str, key: str) -> None:
    """Refuse data [n_bins, n_views] (``key``: sinogram or counts) by name: its second axis, not its
    first, matches the views that ``angles`` and ``times`` count."""
    shape = np.shape(data.get(key))
    views = {np.shape(data[k])[0] if np.ndim(data[k]) == 1 else None for k in ("angles", "times")}
    if len(shape) == 2 and shape[0] != shape[1] and views == {shape[1]}:
        raise InputError(f"{path}: key '{key}': the sinogram looks transposed: got [{shape[0]}, {shape[1]}], expected "
                         f"[n_views={shape[1]}, n_bins={shape[0]}] (angles and times hold {shape[1]} views)")


def working_dtype(values: np.ndarray, path: str, key: str) -> np.ndarray:
    """``values`` as float32, the method's dtype, from any real dtype; one warning line when the cast
    moves a value by more than CAST_TOLERANCE of the values' range. float32 rounds a value by at most
    2^-24 (6e-8) of its magnitude, so values under 16x their range never warn; values far larger than
    their spread (an offset: values near 1e5 that vary by 1) lose detail to the rounding."""
    if values.dtype == np.float32:
        return values
    cast = values.astype(np.float32)
    moved = float(np.max(np.abs(cast.astype(np.float64) - values)))
    spread = float(values.max()) - float(values.min())  # not np.ptp: it overflows in small integer dtypes
    if moved > CAST_TOLERANCE * spread:
        log.warning("%s: key '%s': casting %s to float32 (the method's precision) moves values by up to %.3g, "
                    "%.2g of their range %.3g: values far larger than their spread (an offset?) lose detail",
                    path, key, values.dtype, moved, moved / spread if spread else np.inf, spread)
    return cast


def _geometry(data: dict, path: str, n_bins: int) -> Geometry:
    """The beam and detector from ``bin_spacing`` and the optional geometry keys."""
    given: dict[str, float | str] = {
        key: scalar(data, path, key, positive=key != "detector_offset")
        for key in ("bin_spacing", "source_distance", "detector_distance", "detector_offset")
        if key in data
    }
    if "detector_shape" in data:
        given["detector_shape"] = shape = _text(data, path, "detector_shape")
        if shape not in DETECTOR_SHAPES:
            raise bad_key(path, "detector_shape", "'flat' or 'curved'", repr(shape))
    try:
        return make_geometry(n_bins, **given)
    except ValueError as err:
        raise InputError(f"{path}: {err}") from None


def _text(data: dict, path: str, key: str) -> str:
    """A string-valued key (its single element; several elements are shown as a list)."""
    raw = data[key]
    return str(raw.reshape(-1)[0]) if raw.size == 1 else repr(raw.tolist())


def _check_values(values: np.ndarray, path: str, key: str) -> None:
    """Line integrals of attenuation (from the file's ``key``): not all zero, not mostly negative, not
    absurdly large."""
    if not np.any(values):
        raise bad_key(path, key, "some non-zero line integrals", "all zeros (no object to reconstruct)")
    positive, negative = float(values[values > 0].sum()), float(-values[values < 0].sum())
    if negative > positive:
        raise bad_key(path, key, "line integrals >= 0 (attenuation; noise may dip below 0)",
                      f"mostly negative values (negatives sum to {negative:.3g}, positives to {positive:.3g}): "
                      "a negated sinogram, or counts not turned into -log(I/I0)?")
    largest = float(np.abs(values).max())
    if largest > LARGEST:
        raise bad_key(path, key, f"line integrals below {LARGEST:g} in magnitude",
                      f"values up to {largest:.3g} (a scaling error?)")


def _angles(data: dict, path: str, n_views: int) -> np.ndarray:
    """View angles in radians; degrees only when ``angles_unit`` says so. Angles that span more
    than MAX_ROTATIONS turns read as radians look like degrees and are refused unless stated."""
    angles = array(data, path, "angles", 1, n_views).astype(np.float64)
    unit = None
    if "angles_unit" in data:
        unit = _text(data, path, "angles_unit")
        if unit not in ANGLES_UNITS:
            raise bad_key(path, "angles_unit", "'rad' or 'deg'", repr(unit))
    if unit == "deg":
        angles = np.deg2rad(angles)
    span = float(np.ptp(angles))
    if span == 0:
        raise bad_key(path, "angles", "angles that advance (the gantry turns)", f"every view at angle {angles[0]:g}")
    if unit is None and span > 2 * np.pi * MAX_ROTATIONS:
        raise bad_key(path, "angles", "radians",
                      f"a span of {span:.4g} ({span / (2 * np.pi):.0f} turns if radians): degrees? convert them "
                      "or add angles_unit='deg' to the file (angles_unit='rad' for a scan this long)")
    return angles


def _load_truth(data: dict, path: str) -> Truth | None:
    if "truth" not in data:
        for key in ("truth_times", "truth_extent", "truth_level", "truth_levels"):
            if key in data:
                raise bad_key(path, "truth", f"present when '{key}' is", "missing")
        return None
    frames = array(data, path, "truth", 3)
    for key in ("truth_times", "truth_extent"):
        if key not in data:
            raise bad_key(path, key, "present when 'truth' is", "missing")
    if frames.shape[1] != frames.shape[2]:
        raise bad_key(path, "truth", "square frames [n_frames, N, N]", f"shape {frames.shape}")
    times = array(data, path, "truth_times", 1, frames.shape[0]).astype(np.float64)
    extent = scalar(data, path, "truth_extent")
    if "truth_level" in data:
        level = scalar(data, path, "truth_level")
    else:
        peak = float(frames.max())
        if peak <= 0:
            raise bad_key(path, "truth", "some positive intensity (to set the Dice level)", "an all-zero truth")
        level = 0.5 * peak
    levels = tuple(float(v) for v in array(data, path, "truth_levels", 1)) if "truth_levels" in data else ()
    return Truth(frames.astype(np.float32), times, extent, level, levels)
