"""One key of a sinogram file checked: a real, finite array of a given rank and length, or a scalar;
each failure one `InputError` line naming the file (or arrays) and the key."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from nct.errors import InputError


def bad_key(path: str | Path, key: str, expected: str, got: str) -> InputError:
    """The error of a bad ``key`` in ``path``: what it should hold, what it holds."""
    return InputError(f"{path}: key '{key}': expected {expected}, got {got}")


def real(a: np.ndarray, path: str, key: str) -> np.ndarray:
    """``a`` (of ``key``) when it is real-valued and finite."""
    if not np.issubdtype(a.dtype, np.floating) and not np.issubdtype(a.dtype, np.integer):
        raise bad_key(path, key, "a real-valued array", f"dtype {a.dtype}")
    if not np.all(np.isfinite(a)):
        raise bad_key(path, key, "finite values", f"{int(np.size(a) - np.isfinite(a).sum())} NaN/inf")
    return a


def array(data: dict, path: str, key: str, ndim: int, length: int | None = None) -> np.ndarray:
    """``data[key]`` when it is a real, finite ``ndim``-D array (of ``length`` along its first axis, if given)."""
    a = data[key]
    if a.ndim != ndim:
        raise bad_key(path, key, f"{ndim}-D array", f"shape {a.shape}")
    if length is not None and a.shape[0] != length:
        raise bad_key(path, key, f"length {length} (one per view/frame)", f"shape {a.shape}")
    return real(a, path, key)


def scalar(data: dict, path: str, key: str, positive: bool = True) -> float:
    """``data[key]`` as a finite real number (``positive``: > 0)."""
    a = data[key]
    if a.size != 1 or not (np.issubdtype(a.dtype, np.floating) or np.issubdtype(a.dtype, np.integer)):
        raise bad_key(path, key, "a real scalar", f"shape {a.shape} dtype {a.dtype}")
    v = float(a.reshape(()))
    if not np.isfinite(v) or (positive and v <= 0):
        raise bad_key(path, key, "a finite positive number", repr(v))
    return v
