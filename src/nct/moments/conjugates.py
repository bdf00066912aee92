"""Does the sinogram alone say that nothing moves? Its conjugate views against their noise.

A still object is seen twice along every line in half a turn: in parallel beam p(θ + π, s) = p(θ, −s), and
motion between the two instants breaks it (fan beam is rebinned to parallel first). Each view is compared with
its mirrored conjugate half a turn later (interpolated linearly in angle), and, as the yardstick of the noise
and the interpolation's error, with the mean of its two neighbours. Their ratio sits near or below 1 where
nothing moves and far above where anything does (over the benchmarks' 118 scene files: still 0.38-1.16 with
noise, ~1e-14 without; moving 1.03-1420: benchmarks/results/speed/conjugate_views).
"""

from __future__ import annotations

import numpy as np

from nct.acquisition.rebin import to_parallel
from nct.acquisition.sinogram import Sinogram


def conjugate_mismatch(sino: Sinogram) -> tuple[float, float]:
    """(conjugate, neighbour): the norms of each view minus its mirrored conjugate half a turn later, and of each
    view minus its neighbours' mean, over the views' norm, over the views that have a conjugate; NaN under half a
    turn."""
    sino = sino if sino.geometry.is_parallel else to_parallel(sino)
    values = np.asarray(sino.values, dtype=np.float64)
    angles = np.unwrap(np.asarray(sino.angles, dtype=np.float64))  # a file's angles may wrap at a turn
    turn = np.abs(angles - angles[0])  # rad from the first view
    has = np.flatnonzero(turn + np.pi <= turn[-1])
    if len(has) < 2:
        return float("nan"), float("nan")
    at = np.interp(turn[has] + np.pi, turn, np.arange(len(turn)))  # fractional index of each conjugate
    low = np.floor(at).astype(int)
    high = np.minimum(low + 1, len(turn) - 1)
    w = (at - low)[:, None]
    conjugate = (1 - w) * values[low] + w * values[high]
    norm = np.linalg.norm(values[has])
    mirrored = np.linalg.norm(conjugate - values[has, ::-1]) / norm
    inner = has[(has > 0) & (has < len(turn) - 1)]
    neighbour = np.linalg.norm(values[inner] - 0.5 * (values[inner - 1] + values[inner + 1])) / norm
    return float(mirrored), float(neighbour)


def conjugate_ratio(sino: Sinogram) -> float:
    """`conjugate_mismatch`'s conjugate over its neighbour term: near or below 1 where nothing moves; NaN under half
    a turn or where the views are all alike (nothing to compare with)."""
    conjugate, neighbour = conjugate_mismatch(sino)
    return conjugate / neighbour if neighbour > 0 else float("nan")
