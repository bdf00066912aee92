"""Raw data: transmission ``counts`` with ``flat`` and ``dark`` fields to line integrals,
−log(clip((counts − dark) / (flat − dark), COUNTS_FLOOR, None)), and the sinogram's I0, mean(flat − dark)."""

from __future__ import annotations

import numpy as np

from nct.acquisition.checks import array, bad_key, real

RAW_KEYS = ("flat", "dark")
COUNTS_FLOOR = 1e-6  # normalised transmission below this (a ray that recorded nothing) is clipped to it


def line_integrals(data: dict[str, np.ndarray], path: str) -> tuple[np.ndarray, float]:
    """−log of the counts normalised by flat and dark fields, and I0 = mean(flat − dark)."""
    counts = array(data, path, "counts", 2).astype(np.float64)
    if counts.min() < 0:
        raise bad_key(path, "counts", "counts >= 0",
                      f"{int((counts < 0).sum())} negative values (min {counts.min():g})")
    if "flat" not in data:
        raise bad_key(path, "flat", "present with 'counts' (the counts without the object)", "missing")
    flat, dark = (_field(data, path, key, counts.shape) for key in RAW_KEYS)
    open_beam = np.broadcast_to(flat - dark, counts.shape)
    if open_beam.min() <= 0:
        raise bad_key(path, "flat", "flat > dark in every bin", f"flat <= dark in {int((open_beam <= 0).sum())} of "
                      f"{open_beam.size} view-bins")
    transmission = np.clip((counts - dark) / open_beam, COUNTS_FLOOR, None)
    return (-np.log(transmission)).astype(np.float32), float(np.mean(flat - dark))


def _field(data: dict[str, np.ndarray], path: str, key: str, shape: tuple[int, int]) -> np.ndarray:
    """A flat or dark field broadcastable to the counts' ``shape``: a scalar, [n_bins], [n_views, 1] or
    [n_views, n_bins] (``dark`` absent: 0)."""
    if key not in data:
        return np.zeros(())
    a = real(data[key], path, key).astype(np.float64)
    try:
        fits = np.broadcast_shapes(a.shape, shape) == shape
    except ValueError:
        fits = False
    if not fits:
        raise bad_key(path, key, f"a scalar, [n_bins] or [n_views, n_bins] (broadcastable to counts {list(shape)})",
                      f"shape {a.shape}")
    return a
