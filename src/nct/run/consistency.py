"""Whether the file's geometry fits its own data, from the sinogram alone (a fit absorbs a wrong
geometry as motion, so the held-out misfits of `nct.run.suspect` do not show it).

In parallel beam each view's first moment is e(θ)·c(t), the mass centroid c projected on the
detector, and its total Σ p is the mass M(t), for any object, moving or not
(`method.trajectory.centroid_projections`; fan beam is rebinned first, its views within the fan
angle of the scan's ends dropped: rebinning fills them from rays half a turn away, which a wrong
offset shifts the other way). Two departures name a cause:

* a constant δ added to every first moment (views 180° apart disagree): a wrong detector_offset;
* totals that swing as 1/(1 + r/D) with the centroid's position r along the rays, a fan beam's
  magnification (source-to-detector D): a fan-beam scan read as parallel beam.

c(t) and M(t) are polynomials in time of DEGREES_PER_ROTATION × rotations. Motion as fast as the
gantry can mimic either (a disc orbiting 300°/rotation reads as a 20-bin offset), so each counts
only when every model that can tell agrees; the offset, only for a centroid that barely moves.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.polynomial import legendre

from nct.acquisition.rebin import parallel_geometry_for
from nct.acquisition.sinogram import Sinogram
from nct.moments.trajectory import centroid_projections
from nct.run.conf import SuspectConf

DEGREES_PER_ROTATION = (1, 2, 3)  # the motion models: polynomials of these degrees per gantry rotation
MAX_SE = 0.5  # bins: a model whose offset has a larger standard error cannot tell (its motion mimics a constant)


@dataclass(frozen=True)
class OffsetEstimate:
    """The detector offset the views' first moments call for, in detector bins (the file's pitch;
    positive: the data sit towards higher bins than the file's geometry says). ``per_model``: each
    centroid model's estimate; ``standard_errors``: theirs; ``bins``: the offset that every model
    able to tell (standard error below MAX_SE) needs, their smallest with their common sign; 0 when
    they disagree in sign or none can tell. ``motion_bins``: RMS of the moments about a still
    object's (a sinusoid plus the offset): how much the centroid moves, noise included."""

    bins: float
    per_model: tuple[float, ...]
    standard_errors: tuple[float, ...]
    motion_bins: float


@dataclass(frozen=True)
class FanSwing:
    """How a parallel-beam file's view totals swing with the centroid's position r along the rays:
    per model, the source-to-detector distance D (in field radii) of the fan beam whose
    magnification 1/(1 + r/D) fits the swing beside a smooth mass M(t) (inf: no swing, negative:
    the opposite sign), and how many standard errors that swing stands clear of none.
    ``radii``, ``nearest``: the largest and smallest D of the models; ``sigmas``: the fewest."""

    radii: float
    nearest: float
    sigmas: float
    per_model: tuple[float, ...]
    sigmas_per_model: tuple[float, ...]


@dataclass(frozen=True)
class GeometryCheck:
    """metrics.json's ``geometry_check``: `OffsetEstimate` and, for parallel-beam files, `FanSwing`."""

    offset: OffsetEstimate
    fan: FanSwing | None


def _basis(tau: np.ndarray, degree: int) -> np.ndarray:
    """Legendre polynomials up to ``degree`` at τ ∈ [−1, 1]: [V, degree + 1]."""
    return legendre.legvander(tau, degree)


def _centroid_design(theta: np.ndarray, basis: np.ndarray, offset: bool) -> np.ndarray:
    """Columns of cos θ·x(τ) + sin θ·y(τ) (+ δ): [V, 2·K (+1)] for a [V, K] ``basis``."""
    columns = [basis * np.cos(theta)[:, None], basis * np.sin(theta)[:, None]]
    return np.concatenate(columns + ([np.ones((len(theta), 1))] if offset else []), axis=1)


def _lstsq(design: np.ndarray, target: np.ndarray) -> tuple[np.ndarray, float, float]:
    """Least squares: the solution, the residual sum of squares and the last coefficient's standard error."""
    solution, *_ = np.linalg.lstsq(design, target, rcond=None)
    rss = float(np.sum((target - design @ solution) ** 2))
    dof = max(len(target) - design.shape[1], 1)
    return solution, rss, math.sqrt(max(rss / dof * np.linalg.pinv(design.T @ design)[-1, -1], 0.0))


def _offset(theta: np.ndarray, tau: np.ndarray, moments: np.ndarray, degrees: list[int]) -> OffsetEstimate:
    """`OffsetEstimate` from first moments [V] in bins under centroid models of ``degrees``."""
    fits = [_lstsq(_centroid_design(theta, _basis(tau, d), True), moments) for d in degrees]
    deltas = tuple(float(s[-1]) for s, _, _ in fits)
    errors = tuple(se for _, _, se in fits)
    telling = [d for d, e in zip(deltas, errors) if e < MAX_SE]
    agree = bool(telling) and len({math.copysign(1.0, d) for d in telling}) == 1
    _, still, _ = _lstsq(_centroid_design(theta, _basis(tau, 0), True), moments)
    return OffsetEstimate(min(telling, key=abs) if agree else 0.0, deltas, errors, math.sqrt(still / len(tau)))


def _fan_swing(theta: np.ndarray, tau: np.ndarray, moments: np.ndarray, totals: np.ndarray,
               degrees: list[int]) -> FanSwing:
    """`FanSwing` from first moments [V] in field radii and totals [V]."""
    radii, sigmas = [], []
    for degree in degrees:
        basis = _basis(tau, degree)
        solution, _, _ = _lstsq(_centroid_design(theta, basis, False), moments)
        x, y = basis @ solution[:degree + 1], basis @ solution[degree + 1:]
        along = -x * np.sin(theta) + y * np.cos(theta)  # r: the centroid along the rays d(θ)
        relative = totals / totals.mean()
        swing, _, se = _lstsq(np.concatenate([basis, along[:, None]], axis=1), relative)
        radii.append(-1.0 / swing[-1] if swing[-1] else math.inf)
        sigmas.append(abs(swing[-1]) / se if se > 0 else math.inf)
    return FanSwing(max(radii), min(radii), min(sigmas), tuple(radii), tuple(sigmas))


def check_geometry(sino: Sinogram) -> GeometryCheck | None:
    """The geometry checks on ``sino``; None when fewer than 3 views hold mass or the times do not
    advance (nothing to judge by)."""
    moments = centroid_projections(sino)
    theta = np.unwrap(np.asarray(sino.angles, dtype=np.float64))
    phi, _ = sino.geometry.lines(np.zeros(1), sino.geometry.bin_edges)
    fan = float(np.abs(phi).max())  # half the fan angle (0 in parallel beam)
    ok = np.isfinite(moments) & (np.abs(theta - theta[0]) >= fan) & (np.abs(theta[-1] - theta) >= fan)
    times = np.asarray(sino.times, dtype=np.float64)[ok]
    if ok.sum() < 3 or not times[-1] > times[0]:
        return None
    theta, moments = theta[ok], moments[ok]
    tau = 2 * (times - times[0]) / (times[-1] - times[0]) - 1
    rotations = abs(theta[-1] - theta[0]) / (2 * math.pi)
    degrees = [d for d in (max(1, math.ceil(k * rotations)) for k in DEGREES_PER_ROTATION)
               if 2 * d + 3 < len(tau)] or [0]
    pitch = parallel_geometry_for(sino.geometry).bin_spacing  # the file's pitch at the axis
    offset = _offset(theta, tau, moments / pitch, degrees)
    if not sino.geometry.is_parallel:
        return GeometryCheck(offset, None)
    totals = np.asarray(sino.values, dtype=np.float64)[ok].sum(axis=1)
    radius = sino.geometry.field_radius
    return GeometryCheck(offset, _fan_swing(theta, tau, moments / radius, totals, degrees))


def geometry_warnings(check: GeometryCheck | None, sino: Sinogram, conf: SuspectConf) -> list[str]:
    """status.json's lines: a detector offset above ``conf.offset_bins`` called for by a centroid
    that moves less than ``conf.offset_motion_bins``; totals that swing like a fan beam's in every
    model (source to detector from 1 to ``conf.fan_radii`` field radii, more than
    ``conf.fan_sigmas`` standard errors clear of no swing)."""
    if check is None:
        return []
    out = []
    offset, fan = check.offset, check.fan
    if abs(offset.bins) > conf.offset_bins and offset.motion_bins < conf.offset_motion_bins:
        shift = offset.bins * sino.geometry.bin_spacing
        out.append(f"suspect geometry: views 180 deg apart disagree as if the detector were shifted by "
                   f"{offset.bins:.3g} bins ({shift:.3g} in the file's length unit; every motion model tried needs "
                   f"it; limit suspect.offset_bins={conf.offset_bins:g}): detector_offset or the centre of "
                   "rotation is likely wrong")
    if fan is not None and 1.0 < fan.nearest and fan.radii < conf.fan_radii and fan.sigmas > conf.fan_sigmas:
        distance = fan.radii * sino.geometry.field_radius
        out.append(f"suspect geometry: the views' totals swing with the object's distance from the detector as a "
                   f"fan beam's do (source to detector ~{distance:.3g} in the file's length unit, {fan.radii:.2g} "
                   f"field radii, {fan.sigmas:.2g} standard errors clear of none; limits suspect.fan_radii="
                   f"{conf.fan_radii:g}, suspect.fan_sigmas={conf.fan_sigmas:g}): a fan-beam scan read as "
                   "parallel beam (source_distance, detector_distance missing)?")
    return out
