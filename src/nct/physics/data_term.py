"""The sinogram data term of SinogramFit: how rendered views are compared with the measured ones.

Noise model: a line integral p stands for Poisson counts n = I0·exp(−k·p), k the sinogram's
``attenuation`` (1 for −log of normalised counts; ``simulate.py``'s own scale for its scenes), so the measured p has noise
std σ(p) = exp(k·p / 2) / (k·√I0), larger where fewer photons pass. σ is computed from the
measured values (never the truth), from I0 when the data give it, else from I0 estimated from
the data's own view-to-view fluctuations.

Terms (``loss.data_term``), each relative to the data's mean |value| as before:
``l1``: mean |r|. ``poisson``: mean Huber(r; σ), quadratic within the ray's noise std σ (the
Poisson likelihood's weights 1/σ² there) and |r| beyond it (robust to what the model cannot
explain); it is the L1 term where σ is 0 (noiseless data).
"""

from __future__ import annotations

import logging
import math

import numpy as np
import torch
from torch import Tensor

from nct.acquisition.sinogram import Sinogram

log = logging.getLogger(__name__)

DATA_TERMS = ("l1", "poisson")
MAD_TO_STD = 1.4826  # std of a normal variable per median absolute deviation


def noise_std(values: np.ndarray, i0: float, k: float) -> np.ndarray:
    """Poisson noise std of each measured line integral: [V, B] -> [V, B] float32.
    ``i0``: incident photons per ray; ``k``: attenuation of a unit line integral."""
    return (np.exp(0.5 * k * np.asarray(values, dtype=np.float64)) / (k * math.sqrt(i0))).astype(np.float32)


def estimate_i0(values: np.ndarray, k: float) -> float:
    """I0 from the data alone: the noise of each view against its two neighbours' mean, scaled to a
    photon-rich ray (× exp(−k·p / 2)), robustly (median); inf when the data show no noise.
    values: [V, B] line integrals, views in acquisition order (neighbours close in angle)."""
    v = np.asarray(values, dtype=np.float64)
    if v.shape[0] < 3:
        return math.inf
    wiggle = (v[1:-1] - 0.5 * (v[:-2] + v[2:])) / math.sqrt(1.5)  # std σ for white noise
    sigma = MAD_TO_STD * float(np.median(np.abs(wiggle) * np.exp(-0.5 * k * v[1:-1])))
    return math.inf if sigma == 0 else 1.0 / (k * sigma) ** 2


def view_noise(sino: Sinogram, term: str) -> Tensor | None:
    """Noise std [V, B] of ``sino``'s values (in any units: its ``attenuation`` k makes k·p the
    transmission's exponent) for the data ``term``: None for l1; from ``sino.i0``, else from I0
    estimated from the values."""
    if term == "l1":
        return None
    k = sino.attenuation
    i0 = sino.i0 if sino.i0 is not None else estimate_i0(sino.values, k)
    log.info("data term %s: I0 %.3g counts per ray (%s)", term, i0, "given" if sino.i0 is not None else "estimated")
    return torch.from_numpy(noise_std(sino.values, i0, k))


def misfit(render: Tensor, values: Tensor, sigma: Tensor | None, scale: float) -> Tensor:
    """The data term over a batch of views, relative to ``scale``: L1 when ``sigma`` is None, else
    mean Huber(r; sigma) (sigma [v, B], the noise std of each value). render, values: [v, B]."""
    r = (render - values).abs()
    if sigma is None:
        return r.mean() / scale
    inside = torch.relu(sigma - r)
    return (r - 0.5 * sigma + inside.square() / (2 * sigma.clamp_min(1e-12))).mean() / scale
