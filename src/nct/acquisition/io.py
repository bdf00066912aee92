"""The sinogram file: one ``.npz`` written by every run and read by ``data=file``.

Keys: ``sinogram`` [n_views, n_bins] (any real dtype, read as float32: `keys.working_dtype`), ``angles``
[n_views] radians (degrees with ``angles_unit`` "deg"), ``times`` [n_views] seconds (non-decreasing;
milliseconds with ``data.times_unit=ms``, ``truth_times`` too: `times.py`), ``bin_spacing`` scalar;
optional ``detector_offset`` (default 0), and fan beam when ``source_distance`` is present, with
``detector_distance`` (both > 0) and optional ``detector_shape`` ("flat" default, or "curved"):
the convention of ``geometry.py``; for scoring
``truth`` [n_frames, H, W] with ``truth_times`` [n_frames] and ``truth_extent`` scalar (and
optionally ``truth_level`` and ``truth_levels`` [K], each object's own level).

Raw data instead of ``sinogram``: ``counts`` [n_views, n_bins] (>= 0) with ``flat`` and optional
``dark`` (default 0), each a scalar, [n_bins] or [n_views, n_bins]; the line integrals are
−log(clip((counts − dark) / (flat − dark), COUNTS_FLOOR, None)) (`counts.py`) and the sinogram's
``i0`` the mean of flat − dark (a line-integral file may state ``i0`` itself, with ``attenuation``, the
k of its values' transmission exp(−k·p), default 1). A TIFF stack (``.tif``/``.tiff``,
[n_views, n_bins]) holds ``counts`` when its sidecar ``.npz`` (every other key) has ``flat``, else
``sinogram``. The keys are checked by `keys.parse`.
"""

from __future__ import annotations

import zipfile
from pathlib import Path

import numpy as np

from nct.acquisition.checks import bad_key
from nct.acquisition.keys import DATA_KEYS, parse
from nct.acquisition.sinogram import Sinogram
from nct.errors import InputError

TIFF_SUFFIXES = (".tif", ".tiff")
LISTED_FILES = 5  # a directory given as data.path: its data files are listed when there are at most this many


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


def _read(data, path: Path, key: str) -> np.ndarray:
    """``data[key]``; an object (pickled) array is refused, naming the key."""
    try:
        return np.asarray(data[key])
    except ValueError:
        raise bad_key(path, key, "a numeric array", "an object array (saved with pickling)") from None


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
            raise bad_key(source, key, "no data in the sidecar (the TIFF stack holds them)", "the key present")
    arrays["counts" if "flat" in arrays else "sinogram"] = stack
    return arrays, source
