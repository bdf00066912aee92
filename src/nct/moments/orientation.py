"""Where a lone rigid mover points, read off the sinogram's second moments (the turn its carried field holds).

In parallel beam the central second moment of each view, Σ (u − ū)²·p(u) / Σ p(u), is exactly
e(θ)ᵀ Σ(t) e(θ): the mass's second-moment matrix Σ seen along the detector direction e(θ) at that
view's instant. For a rigid shape of principal moments λ1 ≥ λ2 turned by φ(t) this is
A + B cos 2(θ − φ(t)) with A = (λ1 + λ2) / 2 and B = (λ1 − λ2) / 2, whatever its translation: one
number per view, and φ(t) smooth. The mirror answer 2θ(t) − φ(t) explains the views as well; it turns
faster than the gantry, so the search keeps to slower turns. A disc (B = 0) has no axis to hold, and
a shape that changes explains its views' moments by no A, B and φ: neither is held.

One turning part among still ones (K > 1, the whole mass's centroid still) adds the still rest's
quadratic form to its own: A + B0 cos 2θ + C0 sin 2θ + B cos 2(θ − φ(t)) (`turning_part`). Its turn is
told from the rest's terms only where it turns against the image and against the gantry both.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.polynomial.legendre import legval, legvander
from scipy.optimize import least_squares
from threadpoolctl import threadpool_limits

from nct.acquisition.sinogram import Sinogram
from nct.moments.trajectory import MIN_MASS, centroid_projections

ELONGATED = 0.2  # an axis exists where (λ1 − λ2) / (λ1 + λ2) = B / A reaches this (the start masks' rule too)
# The rigid model must explain the views' second moments to this share of B (RMS): the bar reads 4e-5
# noise-free and 0.02 at I0 = 1e4, heart_cine 0.40, the letters 0.15 (tests/moments/test_orientation.py:
# an ellipse growing by half, not held).
STEADY_SHAPE = 0.05
TERMS_PER_ROTATION = 2  # φ's Legendre terms per rotation of the scan: a steady turn within each rotation
SEARCH_STEP = math.radians(1.0)  # the grid of steady turns searched first, radians per rotation
# A part's turn is told apart from the still rest's terms where it turns by this much over the scan
# (degrees; cos 2(θ − φ) differs from cos 2θ by up to 2 sin φ: 0.52 of its norm at 15°) and its frame is
# seen over this much view angle (a turn with the gantry makes its terms constant). Over the 100
# generalisation scenes (benchmarks/diagnostics/turning_part.py --scenes all) the rules hold on six of the
# ten with one part turning among still ones and on scene029 (two turning: the larger one's), each turn
# within 1°/rotation, and on no other; a translation beside a still object read 3°/scan, still scenes ±359°.
PART_TURN = 15.0
PART_COVERAGE = 90.0
# The part model holds the whole mass's centroid still: the views' centroids must fit one still centre's
# projections to this RMS (detector bins). Those seven read 0.002-0.023 (noise included); scenes with a
# translating object 0.09-1.5, and a disc orbiting beside a still one (tests/init/test_starts.py),
# whose relative offset's quadratic form turns like a part, far more.
STILL_CENTRE = 0.05


def second_moments(sino: Sinogram) -> np.ndarray:
    """Central second moment of each view, Σ_i (u_i − ū)²·p_i / Σ_i p_i over the bins at detector
    coordinates u_i: [V] float64 (length units²); NaN where the view holds less than MIN_MASS of the
    median view's mass (trajectory.centroid_projections). Parallel beam only (fan: ValueError)."""
    if not sino.geometry.is_parallel:
        raise ValueError("second moments are read in parallel beam only")
    values = np.asarray(sino.values, dtype=np.float64)
    u = np.asarray(sino.geometry.bin_positions, dtype=np.float64)
    mass = values.sum(axis=1)
    floor = MIN_MASS * max(float(np.median(mass)), 0.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        mean = values @ u / mass
        return np.where(mass > floor, values @ (u * u) / mass - mean * mean, np.nan)


@dataclass(frozen=True)
class Orientation:
    """A principal axis φ(t) from `orientation_path`: Legendre ``coefficients`` [n] of φ (rad,
    counter-clockwise from x) over the scan of ``span`` rotations from ``start_time`` (s), one rotation
    every ``rotation_time`` s; the views' moments' ``isotropic`` A and ``anisotropy`` B (length
    units²) and the model's RMS ``residual`` there; ``part``: one turning part's among still ones
    (`turning_part`), not a lone shape's."""

    start_time: float
    rotation_time: float
    span: float
    coefficients: np.ndarray
    isotropic: float
    anisotropy: float
    residual: float
    part: bool = False

    def at(self, times: np.ndarray) -> np.ndarray:
        """φ at ``times`` [T] s: [T] rad."""
        tau = (np.asarray(times, dtype=np.float64) - self.start_time) / self.rotation_time
        return legval(2 * tau / self.span - 1, self.coefficients)

    @property
    def held(self) -> bool:
        """Whether the axis is one to hold: the shape rigid (STEADY_SHAPE) and, a lone shape, elongated
        (ELONGATED; a ``part``'s is held against its still rest's terms: `turning_part`)."""
        rigid = self.residual <= STEADY_SHAPE * self.anisotropy
        return rigid and (self.part or self.anisotropy >= ELONGATED * self.isotropic)


def frame_coverage(sino: Sinogram, axis: Orientation) -> float:
    """Degrees of view angle over which the object's own frame is seen: the span of θ − φ(t) over
    ``sino``'s views. Parallel views over 180° determine a still shape; a turning one seen over less
    is left partly to the prior (the bar turning 300°/rotation over one rotation: 60°)."""
    relative = np.unwrap(np.asarray(sino.angles, dtype=np.float64) - axis.at(np.asarray(sino.times, dtype=np.float64)))
    return float(np.degrees(np.ptp(relative)))


def orientation_path(sino: Sinogram) -> Orientation | None:
    """The principal axis that best explains ``sino``'s second moments as a rigid shape's (module
    docstring), or None in fan beam (a rebinned view mixes instants) and with fewer than 3 usable
    views. Steady turns of less than one rotation per gantry rotation are searched on a grid (each
    a linear least-squares fit of A, B cos 2φ0, B sin 2φ0), then φ's Legendre series
    (TERMS_PER_ROTATION) is refined by nonlinear least squares."""
    return _read(sino, part=False)


def turning_part(sino: Sinogram) -> Orientation | None:
    """The axis of one turning part among still ones that best explains ``sino``'s second moments
    (module docstring; searched and refined as `orientation_path`, with the still rest's two terms),
    ``part`` set; None in fan beam, with fewer than 5 usable views, where the whole mass's centroid is not
    still (STILL_CENTRE) and where the turn cannot be told from the rest's terms: under PART_TURN degrees
    over the scan, or its frame seen over less than PART_COVERAGE degrees of view angle (`frame_coverage`)."""
    if not sino.geometry.is_parallel:
        return None
    if still_centre_misfit(sino) > STILL_CENTRE * sino.geometry.bin_spacing:  # cheap: before the turns' grid
        return None
    axis = _read(sino, part=True)
    if axis is None:
        return None
    turn = np.degrees(np.ptp(axis.at(axis.start_time + np.linspace(0, axis.span, 64) * axis.rotation_time)))
    return axis if turn >= PART_TURN and frame_coverage(sino, axis) >= PART_COVERAGE else None


def still_centre_misfit(sino: Sinogram) -> float:
    """RMS misfit of parallel views' centroids (trajectory.centroid_projections) to one still centre's
    projections, e(θ)·c, c fitted by least squares: length units."""
    centroids, theta = centroid_projections(sino), np.asarray(sino.angles, dtype=np.float64)
    ok = np.isfinite(centroids)
    design = np.stack([np.cos(theta), np.sin(theta)], axis=1)[ok]
    centre, *_ = np.linalg.lstsq(design, centroids[ok], rcond=None)
    return float(np.sqrt(np.mean((design @ centre - centroids[ok]) ** 2)))


def _read(sino: Sinogram, part: bool) -> Orientation | None:
    """`orientation_path` (``part``: `turning_part`) up to its verdict."""
    if not sino.geometry.is_parallel:
        return None
    moments = second_moments(sino)
    angles, times = (np.asarray(a, dtype=np.float64) for a in (sino.angles, sino.times))
    ok = np.isfinite(moments)
    if ok.sum() < (5 if part else 3) or times[-1] <= times[0] or angles[-1] == angles[0]:
        return None
    span = abs(angles[-1] - angles[0]) / (2 * math.pi)
    rotation_time = (times[-1] - times[0]) / span
    theta, tau, m = angles[ok], (times[ok] - times[0]) / rotation_time, moments[ok]
    with threadpool_limits(1):
        return _fit(theta, tau, m, float(times[0]), rotation_time, span, part)


def steady_turn(theta: np.ndarray, tau: np.ndarray, moments: np.ndarray,
                still_rest: bool = False) -> tuple[float, np.ndarray, float]:
    """The steady turn φ = φ0 + ωτ that best explains the views' ``moments`` [V] at angles ``theta``
    [V] rad and rotations ``tau`` [V] since the first view, on a grid of turns slower than the
    gantry's (each a linear least-squares fit): (ω rad per rotation, coefficients of 1, cos 2(θ − ωτ),
    sin 2(θ − ωτ) [and, ``still_rest``, cos 2θ, sin 2θ: a still rest's quadratic form beside one
    turning part], RMS misfit)."""
    turns = np.arange(-2 * math.pi + SEARCH_STEP, 2 * math.pi, SEARCH_STEP)  # the mirror turns faster than 2π
    best = (math.inf, 0.0, np.zeros(5 if still_rest else 3))
    for omega in turns:
        phase = 2 * (theta - omega * tau)
        columns = [np.ones_like(phase), np.cos(phase), np.sin(phase)]
        if still_rest:
            columns += [np.cos(2 * theta), np.sin(2 * theta)]
        design = np.stack(columns, axis=1)
        coef, *_ = np.linalg.lstsq(design, moments, rcond=None)
        misfit = float(np.sqrt(np.mean((design @ coef - moments) ** 2)))
        if misfit < best[0]:
            best = (misfit, omega, coef)
    return best[1], best[2], best[0]


def _fit(theta: np.ndarray, tau: np.ndarray, m: np.ndarray, start: float, rotation_time: float,
         span: float, part: bool) -> Orientation:
    """`_read`'s work on the usable views: angles [V] rad, rotations since the first view [V], moments
    [V]; with ``part``, the still rest's cos 2θ and sin 2θ beside the turning part's terms."""
    omega, coef, _ = steady_turn(theta, tau, m, still_rest=part)
    a, c, s = coef[:3]
    n = max(2, math.ceil(TERMS_PER_ROTATION * span - 1e-9))
    s_scan = 2 * tau / span - 1
    basis = legvander(s_scan, n - 1)
    phi0 = 0.5 * math.atan2(s, c)
    start_coef = np.zeros(n)
    start_coef[0], start_coef[1] = phi0 + omega * span / 2, omega * span / 2  # φ0 + ωτ in Legendre terms
    rest = 2 if part else 0
    still = np.stack([np.cos(2 * theta), np.sin(2 * theta)], axis=1)

    def residuals(q: np.ndarray) -> np.ndarray:
        fitted = q[0] + q[1] * np.cos(2 * (theta - basis @ q[2 + rest:])) - m
        return fitted + still @ q[2:4] if part else fitted

    found = least_squares(residuals, np.concatenate([[a, math.hypot(c, s)], coef[3:], start_coef]), method="lm")
    q = found.x
    isotropic, anisotropy, coefficients = float(q[0]), float(q[1]), q[2 + rest:]
    if anisotropy < 0:  # the same axes turned a quarter turn
        anisotropy, coefficients = -anisotropy, coefficients + np.eye(n)[0] * math.pi / 2
    residual = float(np.sqrt(np.mean(residuals(q) ** 2)))
    return Orientation(start, rotation_time, span, coefficients, isotropic, anisotropy, residual, part)
