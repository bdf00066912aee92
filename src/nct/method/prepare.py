"""What every fit of a run shares about its views: the gantry's clock and the held-out split.

Every n-th view (``heldout.every``) is held out of everything, FBP included, and scores the fit
afterwards: a truth-free number for choosing settings. Time is measured in gantry rotations from
the first view, derived from the views' angles and times.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import replace

import numpy as np
import torch

from nct.acquisition.sinogram import Sinogram


def rotations_since_start(sino: Sinogram) -> Callable[[np.ndarray], torch.Tensor]:
    """Map seconds to gantry rotations since the first view, from the views' angles and times."""
    span_t = float(np.ptp(sino.times))
    turns_per_s = float(np.ptp(np.unwrap(sino.angles))) / (2 * math.pi) / span_t if span_t > 0 else 0.0
    if not turns_per_s > 0:
        raise ValueError("the sinogram's views must span a positive time and gantry angle")
    t0 = float(sino.times[0])
    return lambda t: torch.as_tensor((np.asarray(t, dtype=np.float64) - t0) * turns_per_s, dtype=torch.float32)


def rotations_spanned(sino: Sinogram) -> float:
    """Gantry rotations from the first view to the last."""
    return float(rotations_since_start(sino)(sino.times).max())


def split_views(n_views: int, every: int, run: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """Indices of the fitted and the held-out views: runs of ``run`` consecutive views, every
    ``every``-th run held out (the middle one of each ``every`` runs)."""
    if every < 2:
        return np.arange(n_views), np.zeros(0, dtype=int)
    held = (np.arange(n_views) // run) % every == every // 2
    return np.flatnonzero(~held), np.flatnonzero(held)


def subset(sino: Sinogram, views: np.ndarray) -> Sinogram:
    """The given views of ``sino``, without its truth."""
    return replace(sino, values=sino.values[views], angles=sino.angles[views], times=sino.times[views], truth=None)


def heldout_standard_error(losses: np.ndarray, blocks: int = 10) -> float:
    """Standard error of the mean of per-view held-out ``losses`` [v] (in time order), from the
    means of ``blocks`` contiguous blocks: neighbouring views see nearly the same object and
    angle, so their misfits are not independent. NaN with fewer than 2 views."""
    if len(losses) < 2:
        return float("nan")
    means = [part.mean() for part in np.array_split(losses, min(blocks, len(losses)))]
    return float(np.std(means, ddof=1) / math.sqrt(len(means)))
