"""Object intensities from the sinogram: which of Algorithm 1's candidate levels, and what a(k),
explain the measured views best with the masks they draw.

Algorithm 1 reads each object's level off the FBP frames. Where an object moves fast, FBP spreads
it (a half-turn window sees it at many places), so its level there depends on the motion's
phase; the thin rim of a body around a nested object is all partial volume, and a mixture class
there looks like a blur class. The line integrals hold the objects' true attenuation: with the
masks fixed, the views are linear in a(k), so each candidate's intensities follow from a
nonnegative least-squares fit over the fitted views, and its residual says how well it explains them.
"""

from __future__ import annotations

import hashlib

import numpy as np
import torch
from scipy.optimize import nnls

from nct.acquisition.geometry import Geometry
from nct.init.segmentation import Judge
from nct.physics.projector import project

MAX_VIEWS = 256  # views the judge projects: the residual of a few masks needs no more ...
MAX_PIXELS = 2**25  # ... and fewer where their mask images would hold more pixels than this (memory)
MIN_SHARE = 0.05  # an object's |intensity| is at least this share of the largest (log-parameterised |a(k)| > 0)
FLOOR = 1e-12  # ... and the largest at least this: where every a(k) is 0 the masks explain nothing (`explains_nothing`)


def sinogram_judge(
    mask_times: torch.Tensor,
    values: torch.Tensor,
    angles: torch.Tensor,
    times: torch.Tensor,
    geometry: Geometry,
    extent: float,
) -> Judge:
    """A `segment.Judge` over up to MAX_VIEWS of the views values [V, n_bins], angles [V] rad,
    times [V], spread evenly: each view sees the mask frame nearest its time (``mask_times`` [F],
    same units). Its misfit is the relative residual ||sum_k a(k) P(mask_k) - views|| / ||views||,
    each a(k) of the sign given (nonnegative least squares on |a(k)|). An object's mask often
    recurs from one candidate to the next (half of them with K = 4 or more): each is projected once."""
    projected: dict[tuple[int, bytes], torch.Tensor] = {}  # (views, mask frames' digest) -> [views * n_bins]

    @torch.no_grad()
    def judge(masks: np.ndarray, signs: np.ndarray) -> tuple[float, np.ndarray]:
        pick = picked(values.shape[0], masks[0].size)
        nearest = torch.argmin((times[pick, None] - mask_times[None, :]).abs(), dim=1)
        columns = []
        for k in range(masks.shape[1]):
            frames = np.ascontiguousarray(masks[:, k])  # [F, H, W]
            key = (len(pick), hashlib.blake2b(frames.view(np.uint8)).digest())
            if key not in projected:
                images = torch.from_numpy(frames).float()[nearest]  # [n, H, W]
                projected[key] = project(images, angles[pick], geometry, extent).reshape(-1).double()
            columns.append(projected[key])
        measured = values[pick].reshape(-1).double().numpy()
        a, residual = nnls(torch.stack(columns, dim=1).numpy() * signs, measured)
        a = np.maximum(a, MIN_SHARE * max(float(a.max()), FLOOR))
        return residual / max(float(np.linalg.norm(measured)), 1e-30), signs * a

    return judge


def explains_nothing(intensities: np.ndarray) -> bool:
    """Whether a judged segmentation's ``intensities`` [K] are all at the judge's floor: least squares gave every
    object 0, its masks explain none of the views (objects over a background where nothing moves)."""
    return float(np.abs(intensities).max()) <= MIN_SHARE * FLOOR


def picked(n_views: int, n_pixels: int) -> np.ndarray:
    """The indices of the views [n] the judge compares masks of ``n_pixels`` (K x H x W) with: spread evenly."""
    n = min(MAX_VIEWS, n_views, max(1, MAX_PIXELS // n_pixels))
    return np.linspace(0, n_views - 1, n).round().astype(int)


def views_norm(values: torch.Tensor, n_pixels: int) -> float:
    """The norm of the views ``values`` [V, n_bins] the judge compares masks of ``n_pixels`` with (`picked`): what a
    judged residual is relative to."""
    return float(torch.linalg.norm(values[picked(values.shape[0], n_pixels)].double()))
