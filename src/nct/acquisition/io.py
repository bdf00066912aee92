"""The sinogram file: one ``.npz`` written by every run and read by ``data=file``.

Keys: ``sinogram`` [n_views, n_bins] (any real dtype, read as float32: `working_dtype`), ``angles``
[n_views] radians (degrees with ``angles_unit`` "deg"), ``times`` [n_views] seconds (non-decreasing;
milliseconds with ``data.times_unit=ms``, ``truth_times`` too: `times.py`), ``bin_spacing`` scalar;
optional ``detector_offset`` (default 0), and fan beam when ``source_distance`` is present, with
``detector_distance`` (both > 0) and optional ``detector_shape`` ("flat" default, or "curved"):
the convention of ``geometry.py``; for scoring
``truth`` [n_frames, H, W] with ``truth_times`` [n_frames] and ``truth_extent`` scalar (and
optionally ``truth_level`` and ``truth_levels`` [K], each object's own level).

Raw data instead of ``sinogram``: ``counts`` [n_views, n_bins] (>= 0) with ``flat`` and optional
``dark`` (default 0), each a scalar, [n_bins] or [n_views, n_bins]; the line integrals are
−log(clip((counts − dark) / (flat − dark), COUNTS_FLOOR, None)) and the sinogram's ``i0`` the mean of
flat − dark (a line-integral file may state ``i0`` itself, with ``attenuation``, the k of
its values' transmission exp(−k·p), default 1). A TIFF stack (``.tif``/``.tiff``,
[n_views, n_bins]) holds ``counts`` when its sidecar ``.npz`` (every other key) has ``flat``, else
``sinogram``.
"""

from __future__ import annotations

import logging
import zipfile
from dataclasses import replace
from pathlib import Path

import numpy as np

from nct.acquisition.geometry import DETECTOR_SHAPES, Geometry, make_geometry
from nct.acquisition.sinogram import Sinogram, Truth
from nct.acquisition.times import in_seconds, seconds_per
from nct.errors import InputError

REQUIRED = ("angles", "times", "bin_spacing")  # and the data: ``sinogram``, or ``counts`` with ``flat``
DATA_KEYS = ("sinogram", "counts")
RAW_KEYS = ("flat", "dark")
GEOMETRY_KEYS = ("source_distance", "detector_distance", "detector_shape", "detector_offset")
OPTIONAL = (*GEOMETRY_KEYS, *RAW_KEYS, "truth", "truth_times", "truth_extent", "truth_level", "truth_levels",
            "angles_unit", "i0", "attenuation")
TIFF_SUFFIXES = (".tif", ".tiff")
COUNTS_FLOOR = 1e-6  # normalised transmission below this (a ray that recorded nothing) is clipped to it
ANGLES_UNITS = ("rad", "deg")
MAX_ROTATIONS = 16  # angles in radians spanning more turns than this look like degrees
LARGEST = 1e9  # |line integral| beyond this is no attenuation (a scaling or type error)
CAST_TOLERANCE = 1e-6  # a cast to float32 that moves a value by more than this share of the data's range warns
LISTED_FILES = 5  # a directory given as data.path: its data files are listed when there are at most this many

log = logging.getLogger(__name__)


def save_sinogram(path: str | Path, sino: Sinogram) -> None:
    """Write ``sino`` (and its truth, when present) in the documented ``.npz`` format."""
    arrays: dict[str, np.ndarray] = {
        "sinogram": np.asarray(sino.values, dtype=np.float32),
        "angles": np.asarray(sino.angles, dtype=np.float64),
        "times": np.asarray(sino.times, dtype=np.float64),
    }
    for key, value in sino.geometry.keys().items():
        arrays[key] = np.str_(value) if isinstance(value, str) else np.float64(value)
    if sino.i0 is not None:
        arrays["i0"] = np.float64(sino.i0)
        arrays["attenuation"] = np.float64(sino.attenuation)
    if sino.truth is not None:
        arrays["truth"] = np.asarray(sino.truth.frames, dtype=np.float32)
        arrays["truth_times"] = np.asarray(sino.truth.times, dtype=np.float64)
        arrays["truth_extent"] = np.float64(sino.truth.extent)
        arrays["truth_level"] = np.float64(sino.truth.level)
        if sino.truth.levels:
            arrays["truth_levels"] = np.asarray(sino.truth.levels, dtype=np.float64)
    np.savez_compressed(Path(path), **arrays)


def _fail(path: str | Path, key: str, expected: str, got: str) -> InputError:
    return InputError(f"{path}: key '{key}': expected {expected}, got {got}")


def _read(data, path: Path, key: str) -> np.ndarray:
    """``data[key]``; an object (pickled) array is refused, naming the key."""
    try:
        return np.asarray(data[key])
    except ValueError:
        raise _fail(path, key, "a numeric array", "an object array (saved with pickling)") from None


def _check_real(a: np.ndarray, path: str, key: str) -> np.ndarray:
    if not np.issubdtype(a.dtype, np.floating) and not np.issubdtype(a.dtype, np.integer):
        raise _fail(path, key, "a real-valued array", f"dtype {a.dtype}")
    if not np.all(np.isfinite(a)):
        raise _fail(path, key, "finite values", f"{int(np.size(a) - np.isfinite(a).sum())} NaN/inf")
    return a


def _array(data: dict, path: str, key: str, ndim: int, length: int | None = None) -> np.ndarray:
    a = data[key]
    if a.ndim != ndim:
        raise _fail(path, key, f"{ndim}-D array", f"shape {a.shape}")
    if length is not None and a.shape[0] != length:
        raise _fail(path, key, f"length {length} (one per view/frame)", f"shape {a.shape}")
    return _check_real(a, path, key)


def _scalar(data: dict, path: str, key: str, positive: bool = True) -> float:
    a = data[key]
    if a.size != 1 or not (np.issubdtype(a.dtype, np.floating) or np.issubdtype(a.dtype, np.integer)):
        raise _fail(path, key, "a real scalar", f"shape {a.shape} dtype {a.dtype}")
    v = float(a.reshape(()))
    if not np.isfinite(v) or (positive and v <= 0):
        raise _fail(path, key, "a finite positive number", repr(v))
    return v


def load_sinogram(path: str | Path, sidecar: str | Path | None = None, times_unit: str | None = None) -> Sinogram:
    """Read and validate a sinogram file (``.npz``, or a TIFF stack with its ``sidecar`` ``.npz``,
    by default the TIFF's name ending ``.npz``; its ``times`` in ``times_unit``, s or ms, None: s);
    raise `InputError` naming the first bad key."""
    path = _existing_file(Path(path), "data.path")
    if path.suffix.lower() in TIFF_SUFFIXES:
        return parse(*_read_tiff(path, path.with_suffix(".npz") if sidecar is None else Path(sidecar)), times_unit)
    if sidecar is not None:
        raise InputError(f"data.sidecar: only a TIFF stack (data.path=*.tif) takes a sidecar, not {path}")
    return parse(_read_npz(path, "data.path"), str(path), times_unit)


def _existing_file(path: Path, config_key: str) -> Path:
    """``path`` when it is a file; else `InputError` saying it is missing or a directory (naming the
    directory's .npz and TIFF files when there are few)."""
    if path.is_dir():
        found = sorted(p.name for p in path.iterdir() if p.suffix.lower() in (".npz", *TIFF_SUFFIXES))
        listing = ("it holds no .npz or .tif files" if not found else f"it holds {len(found)} .npz/.tif files"
                   if len(found) > LISTED_FILES else "it holds " + ", ".join(found))
        raise InputError(f"{config_key}: {path} is a directory, not a file: name a sinogram file in it ({listing})")
    if not path.is_file():
        raise InputError(f"{config_key}: no such file: {path}")
    return path


def _read_npz(path: Path, config_key: str) -> dict[str, np.ndarray]:
    """Every array of an ``.npz`` file (``config_key``: the setting that named it, for errors)."""
    try:
        data = np.load(path, allow_pickle=False)
    except (OSError, ValueError, zipfile.BadZipFile) as err:
        raise InputError(f"{config_key}: {path} is not a readable .npz file ({err})") from None
    with data:
        return {key: _read(data, path, key) for key in data.files}


def _read_tiff(path: Path, sidecar: Path) -> tuple[dict[str, np.ndarray], str]:
    """The TIFF stack as ``counts`` (when the sidecar has ``flat``) or ``sinogram``, with the sidecar's keys."""
    import tifffile  # lazy: the config schemas import this module's package, and most files are .npz

    try:
        stack = np.squeeze(tifffile.imread(path))
    except (OSError, ValueError) as err:
        raise InputError(f"data.path: {path} is not a readable TIFF file ({err})") from None
    if not sidecar.exists():
        raise InputError(f"data.sidecar: no such file: {sidecar} (a TIFF stack needs an .npz of its angles, "
                         "times, bin_spacing and other keys: see docs/DATA.md)")
    arrays = _read_npz(_existing_file(sidecar, "data.sidecar"), "data.sidecar")
    source = f"{path} + {sidecar}"
    for key in DATA_KEYS:
        if key in arrays:
            raise _fail(source, key, "no data in the sidecar (the TIFF stack holds them)", "the key present")
    arrays["counts" if "flat" in arrays else "sinogram"] = stack
    return arrays, source


def parse(data: dict[str, np.ndarray], path: str, times_unit: str | None = None) -> Sinogram:
    """The validated sinogram of the arrays ``data`` (a file's keys, or a `Scan`'s) from ``path`` (times: ``times_unit``)."""
    for key in REQUIRED:
        if key not in data:
            raise _fail(path, key, "present (required keys: sinogram or counts, " + ", ".join(REQUIRED) + ")",
                        "missing")
    unknown = sorted(set(data) - set(REQUIRED) - set(DATA_KEYS) - set(OPTIONAL))
    if unknown:
        raise _fail(path, unknown[0], "one of " + ", ".join(DATA_KEYS + REQUIRED + OPTIONAL), "an unknown key")
    data_key = "counts" if "counts" in data else "sinogram"
    _check_orientation(data, path, data_key)
    values, i0 = _values(data, path)
    if values.shape[0] < 2 or values.shape[1] < 2:
        raise _fail(path, data_key, "shape [n_views >= 2, n_bins >= 2]", f"shape {values.shape}")
    _check_values(values, path, data_key)
    values = working_dtype(values, path, data_key)
    n_views = values.shape[0]
    angles = _angles(data, path, n_views)
    times = _array(data, path, "times", 1, n_views).astype(np.float64)
    if np.any(np.diff(times) < 0):
        raise _fail(path, "times", "non-decreasing times", "times that go backwards")
    if np.ptp(times) == 0:
        raise _fail(path, "times", "times that advance over the scan", f"every view at the same time {times[0]:g}")
    times = in_seconds(angles, times, times_unit, path)
    geometry = _geometry(data, path, values.shape[1])
    truth = _load_truth(data, path)
    if truth is not None:
        truth = replace(truth, times=truth.times * seconds_per(times_unit))
    attenuation = _scalar(data, path, "attenuation") if "attenuation" in data else 1.0
    return Sinogram(values, angles, times, geometry, truth=truth, i0=i0, attenuation=attenuation)


def _values(data: dict[str, np.ndarray], path: str) -> tuple[np.ndarray, float | None]:
    """The line integrals [n_views, n_bins] float32 and the incident intensity I0 (None if unknown)."""
    present = [key for key in DATA_KEYS if key in data]
    if len(present) != 1:
        raise _fail(path, "sinogram", "either 'sinogram' (line integrals) or 'counts' (with 'flat' and 'dark')",
                    "both" if present else "neither")
    i0 = _scalar(data, path, "i0") if "i0" in data else None
    if present == ["counts"]:
        if i0 is not None:
            raise _fail(path, "i0", "absent with 'counts' (I0 is the mean of flat - dark)", repr(i0))
        return _line_integrals(data, path)
    for key in RAW_KEYS:
        if key in data:
            raise _fail(path, key, "only with 'counts' (raw data), not with 'sinogram'", "the key present")
    return _array(data, path, "sinogram", 2), i0


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


def _line_integrals(data: dict[str, np.ndarray], path: str) -> tuple[np.ndarray, float]:
    """−log of the counts normalised by flat and dark fields, and I0 = mean(flat − dark)."""
    counts = _array(data, path, "counts", 2).astype(np.float64)
    if counts.min() < 0:
        raise _fail(path, "counts", "counts >= 0", f"{int((counts < 0).sum())} negative values (min {counts.min():g})")
    if "flat" not in data:
        raise _fail(path, "flat", "present with 'counts' (the counts without the object)", "missing")
    flat, dark = (_field(data, path, key, counts.shape) for key in RAW_KEYS)
    open_beam = np.broadcast_to(flat - dark, counts.shape)
    if open_beam.min() <= 0:
        raise _fail(path, "flat", "flat > dark in every bin", f"flat <= dark in {int((open_beam <= 0).sum())} of "
                    f"{open_beam.size} view-bins")
    transmission = np.clip((counts - dark) / open_beam, COUNTS_FLOOR, None)
    return (-np.log(transmission)).astype(np.float32), float(np.mean(flat - dark))


def _field(data: dict[str, np.ndarray], path: str, key: str, shape: tuple[int, int]) -> np.ndarray:
    """A flat or dark field broadcastable to the counts' ``shape``: a scalar, [n_bins], [n_views, 1] or
    [n_views, n_bins] (``dark`` absent: 0)."""
    if key not in data:
        return np.zeros(())
    a = _check_real(data[key], path, key).astype(np.float64)
    try:
        fits = np.broadcast_shapes(a.shape, shape) == shape
    except ValueError:
        fits = False
    if not fits:
        raise _fail(path, key, f"a scalar, [n_bins] or [n_views, n_bins] (broadcastable to counts {list(shape)})",
                    f"shape {a.shape}")
    return a


def _geometry(data: dict, path: str, n_bins: int) -> Geometry:
    """The beam and detector from ``bin_spacing`` and the optional geometry keys."""
    given: dict[str, float | str] = {
        key: _scalar(data, path, key, positive=key != "detector_offset")
        for key in ("bin_spacing", "source_distance", "detector_distance", "detector_offset")
        if key in data
    }
    if "detector_shape" in data:
        given["detector_shape"] = shape = _text(data, path, "detector_shape")
        if shape not in DETECTOR_SHAPES:
            raise _fail(path, "detector_shape", "'flat' or 'curved'", repr(shape))
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
        raise _fail(path, key, "some non-zero line integrals", "all zeros (no object to reconstruct)")
    positive, negative = float(values[values > 0].sum()), float(-values[values < 0].sum())
    if negative > positive:
        raise _fail(path, key, "line integrals >= 0 (attenuation; noise may dip below 0)",
                    f"mostly negative values (negatives sum to {negative:.3g}, positives to {positive:.3g}): "
                    "a negated sinogram, or counts not turned into -log(I/I0)?")
    largest = float(np.abs(values).max())
    if largest > LARGEST:
        raise _fail(path, key, f"line integrals below {LARGEST:g} in magnitude",
                    f"values up to {largest:.3g} (a scaling error?)")


def _angles(data: dict, path: str, n_views: int) -> np.ndarray:
    """View angles in radians; degrees only when ``angles_unit`` says so. Angles that span more
    than MAX_ROTATIONS turns read as radians look like degrees and are refused unless stated."""
    angles = _array(data, path, "angles", 1, n_views).astype(np.float64)
    unit = None
    if "angles_unit" in data:
        unit = _text(data, path, "angles_unit")
        if unit not in ANGLES_UNITS:
            raise _fail(path, "angles_unit", "'rad' or 'deg'", repr(unit))
    if unit == "deg":
        angles = np.deg2rad(angles)
    span = float(np.ptp(angles))
    if span == 0:
        raise _fail(path, "angles", "angles that advance (the gantry turns)", f"every view at angle {angles[0]:g}")
    if unit is None and span > 2 * np.pi * MAX_ROTATIONS:
        raise _fail(path, "angles", "radians",
                    f"a span of {span:.4g} ({span / (2 * np.pi):.0f} turns if radians): degrees? convert them "
                    "or add angles_unit='deg' to the file (angles_unit='rad' for a scan this long)")
    return angles


def _load_truth(data: dict, path: str) -> Truth | None:
    if "truth" not in data:
        for key in ("truth_times", "truth_extent", "truth_level", "truth_levels"):
            if key in data:
                raise _fail(path, "truth", f"present when '{key}' is", "missing")
        return None
    frames = _array(data, path, "truth", 3)
    for key in ("truth_times", "truth_extent"):
        if key not in data:
            raise _fail(path, key, "present when 'truth' is", "missing")
    if frames.shape[1] != frames.shape[2]:
        raise _fail(path, "truth", "square frames [n_frames, N, N]", f"shape {frames.shape}")
    times = _array(data, path, "truth_times", 1, frames.shape[0]).astype(np.float64)
    extent = _scalar(data, path, "truth_extent")
    if "truth_level" in data:
        level = _scalar(data, path, "truth_level")
    else:
        peak = float(frames.max())
        if peak <= 0:
            raise _fail(path, "truth", "some positive intensity (to set the Dice level)", "an all-zero truth")
        level = 0.5 * peak
    levels = tuple(float(v) for v in _array(data, path, "truth_levels", 1)) if "truth_levels" in data else ()
    return Truth(frames.astype(np.float32), times, extent, level, levels)
