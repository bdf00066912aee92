"""Motion series over a scan: Legendre polynomials in the scan's time mapped to [-1, 1], where the
rigid and affine rungs' poses (fields/moved.py) and a carried or turned free field's path (fields/free.py) are
series of them.
"""

from __future__ import annotations

import math

import torch
from numpy.polynomial.legendre import legfit
from torch import Tensor

from nct.fields.conf import ModelConf


def series_terms(conf: ModelConf, span: float) -> int:
    """Legendre terms of a motion series over a scan of ``span`` rotations: ``model.pose_terms_per_rotation``
    per rotation, at least 2 (the rigid and affine poses, the carried path)."""
    return max(2, math.ceil(conf.pose_terms_per_rotation * span - 1e-9))


def on_scan(t: Tensor, span: Tensor) -> Tensor:
    """Times t (rotations) mapped to [-1, 1] over a scan of ``span`` rotations: where Legendre
    polynomials are orthogonal."""
    return 2 * t / span - 1


def legendre(s: Tensor, n: int) -> Tensor:
    """Legendre polynomials P_0 .. P_{n-1} at s [T] (the span is [-1, 1]): [T, n], by numpy
    ``legvander``'s recursion and steps in float64 where s lies (no copy to the host each step; times
    are data, not parameters, so no gradient flows through s), laid out as its answer is, a term's
    values side by side: a product's rounding follows its operands' layout."""
    x = s.detach().double()
    terms = [torch.ones_like(x), x][:n]
    for i in range(2, n):
        terms.append((terms[i - 1] * x * (2 * i - 1) - terms[i - 2] * (i - 1)) / i)
    return torch.stack(terms).T.to(s)


def legendre_fit(s: Tensor, values: Tensor, n: int) -> Tensor:
    """Least-squares coefficients [n, C] of P_0 .. P_{n-1} fitting ``values`` [F, C] at s [F], numpy's
    (``legfit``, in float64: float32 LAPACK's answer changes with where its arrays lie in memory,
    and a seeded run must repeat bit for bit)."""
    fit = legfit(s.detach().cpu().double().numpy(), values.detach().cpu().double().numpy(), n - 1)
    return torch.from_numpy(fit).to(values)
