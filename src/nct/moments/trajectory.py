"""Where the moving mass goes, read off the sinogram, and what of that the data cannot tell.

In parallel beam the first moment of each view, Σ u·p(u) / Σ p(u), is exactly e(θ)·c(t): the
projection of the mass centroid c(t) onto the detector direction e(θ) = (cos θ, sin θ) at that
view's instant (fan beam is rebinned first). Motion along the rays, f(t)·d(θ(t)) with
d = (−sin θ, cos θ), moves no first moment and no disc's sinogram: only a prior over time fills
it in. Issue 27, items 3 and 4; docs/figures/ambiguity.png.

The trajectory is a Fourier series in time (cycles per gantry rotation) whose coefficients have
a Gaussian prior of variance ∝ exp(−2π²ℓ²f²): a squared-exponential Gaussian process of length
scale ℓ rotations, in a fixed basis. Why Fourier: the invisible motion turns with the gantry at
exactly one cycle per rotation, so what decides is how much the prior allows there. ONE rule
chooses ℓ, the prior's amplitude and the noise: the evidence (marginal likelihood). Held-out
views cannot choose: the invisible motion is invisible in them too (least-squares fits of every
order that reach the noise floor agree on held-out views to 1e-4 px and differ from the truth by
up to hundreds of pixels). What the data leave open shows as the spread between equally good
fits under priors RIVAL times shorter and longer (`Trajectory.ray_spread`, `determinacy`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from scipy.linalg import cholesky, solve_triangular
from scipy.optimize import minimize, minimize_scalar
from threadpoolctl import threadpool_limits

from nct.acquisition.rebin import to_parallel
from nct.acquisition.sinogram import Sinogram

MIN_LENGTH = 0.1  # shortest prior length scale, rotations: sets the highest frequency in the basis
MAX_LENGTH = 4.0  # longest; the basis's period is 2·scan + this, so its wrap-around stays out of the scan
CUTOFF = 4.0  # basis frequencies up to CUTOFF / (2π·MIN_LENGTH): there the prior is exp(−8) of its peak
MAX_RATIO = 1e6  # prior amplitude / noise at most: float32 sinograms give centroids to ~1e-6 of the field
RIVAL = 1.5  # rival priors' length scales: the evidence's ℓ divided and multiplied by this
EQUAL = 0.1  # a rival fit is equally good when its RMS misfit is within this fraction of the best's
MIN_MASS = 0.05  # a view holding less than this share of the median view's mass gives no centroid (NaN)
# One rigid mover over a still rest keeps the views' total mass: a change (std over the scan) of this
# share of the mover's own mass means it deforms or something else moves, and the centroid's path is
# not the mover's. Circle, bar 0.0000, the subset's one-object scenes 0.0008-0.032 (noise), the
# vessel in a still body 0.0016 of its own; letters 0.13, heart_cine 0.32 (benchmarks/results/ladder).
MASS_CHANGE = 0.1
UNDETERMINED_PX = 4.0  # `determinacy`: a larger spread along the rays (pixels) is undetermined. Tuned as a
# warning (issue 50): fits stay good up to 2.5 px (the circle at 200 deg/rot over three rotations, Dice 0.990;
# the generalisation scenes' widest, 2.1 px, 0.997) and go poor from 6.1 px (the circle at 300 deg/rot over three
# rotations, 0.756; one rotation, 7.6 px, 0.776): benchmarks/results/warnings/motion_limit/. At 1 px it warned
# only good fits there (3 of 100 scenes, the circle at 200 deg/rot, noisy scans at 100 deg/rot).


def centroid_projections(sino: Sinogram) -> np.ndarray:
    """First moment of each view, Σ_i u_i·p_i / Σ_i p_i over bins at detector coordinates u_i:
    [V] float64 in the geometry's length units, e(θ_v)·c(t_v) for the mass centroid c.

    Parallel beam reads bins at ``geometry.bin_positions`` (detector offset included); fan beam is
    rebinned first (`rebin.to_parallel`: each parallel view then mixes instants within the fan
    angle; exact for a still object). Values are used as they are, negative noise included: clipping
    them at 0 biases every centroid towards the detector's centre (the circle at I0 = 1e4: 0.19 px
    against 0.001 px unclipped). A view holding less than MIN_MASS of the median view's mass
    (nothing in the field, or noise only) comes back NaN, and `fit_trajectory` skips it. An object
    reaching past the detector's ends gives a wrong moment: the field must hold it in every view.
    """
    if not sino.geometry.is_parallel:
        sino = to_parallel(sino)
    values = np.asarray(sino.values, dtype=np.float64)
    mass = values.sum(axis=1)
    floor = MIN_MASS * max(float(np.median(mass)), 0.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(mass > floor, values @ sino.geometry.bin_positions / mass, np.nan)


def centroid_path(sino: Sinogram) -> Trajectory | None:
    """The mass centroid's path read off ``sino``'s first moments (`centroid_projections`,
    `fit_trajectory`) where it can hold a mover: parallel beam only. A rebinned fan view mixes
    instants within the fan angle; its moments put the circle at 100°/rot 7.5 px off its orbit (the
    fan views' own instants make the source's path an exact answer instead). None in fan beam."""
    if not sino.geometry.is_parallel:
        return None
    return fit_trajectory(sino.angles, sino.times, centroid_projections(sino))


def view_masses(sino: Sinogram) -> np.ndarray:
    """Each view's total, Σ_i p_i [V] float64 (fan beam rebinned first): the mass in the field at its instant."""
    if not sino.geometry.is_parallel:
        sino = to_parallel(sino)
    return np.asarray(sino.values, dtype=np.float64).sum(axis=1)


def steady_mass(sino: Sinogram, own: float | None = None) -> bool:
    """Whether the views' total mass stays within MASS_CHANGE (std over the scan) of a mover's ``own``
    (default: the views' median mass, the whole field one mover): its centroid's path is then the mover's."""
    mass = view_masses(sino)
    own = float(np.median(mass)) if own is None else own
    return bool(float(np.std(mass)) < MASS_CHANGE * own)


@dataclass(frozen=True)
class Trajectory:
    """A centroid trajectory c(t) from `fit_trajectory`, and its equally good rivals.

    c(t) = Σ_k a_k cos(2π f_k τ') + b_k sin(2π f_k τ'), τ' = τ − span/2, τ = (t − start_time) /
    rotation_time the gantry rotations since the first view (span: the scan's). frequencies: [K]
    cycles per rotation, f_0 = 0; coefficients: [2K − 1, 2] (x, y) for the cosines, then the sines
    of f_1…. start_angle and turn (±1) give the gantry's angle θ(t) = start_angle + turn·2π·τ.
    length_scale: the prior's ℓ (rotations); noise: the evidence's sd of one view's centroid;
    residual: RMS misfit of the fitted centroids (both in length units). rivals: the fits under
    priors RIVAL times shorter and longer whose misfit is within EQUAL of this one's.
    """

    start_time: float
    rotation_time: float
    span: float
    start_angle: float
    turn: float
    frequencies: np.ndarray
    coefficients: np.ndarray
    length_scale: float
    noise: float
    residual: float
    rivals: tuple[Trajectory, ...] = ()

    def _tau(self, times: np.ndarray) -> np.ndarray:
        return (np.asarray(times, dtype=np.float64) - self.start_time) / self.rotation_time

    def at(self, times: np.ndarray) -> np.ndarray:
        """The centroid at ``times`` [T] s: [T, 2] (x, y) in the sinogram's length units."""
        return _fourier(self._tau(times) - self.span / 2, self.frequencies) @ self.coefficients

    def scaled(self, scale: float, mean: np.ndarray, origin: np.ndarray) -> Trajectory:
        """origin + scale·(c(t) − mean): the path of a part whose motion is ``scale`` times the
        whole mass's (its share of the mass is 1/scale when the rest stands still), without rivals."""
        coefficients = scale * self.coefficients
        coefficients[0] += np.asarray(origin, dtype=np.float64) - scale * np.asarray(mean, dtype=np.float64)
        return replace(self, coefficients=coefficients, rivals=())

    def ray_spread(self, times: np.ndarray) -> np.ndarray:
        """How far the rivals stray from this trajectory along the rays of the view taken at each of
        ``times`` [T] s, max_r |d(θ(t))·(c_r(t) − c(t))|: [T] length units (0 without rivals)."""
        theta = self.start_angle + self.turn * 2 * math.pi * self._tau(times)
        d = np.stack([-np.sin(theta), np.cos(theta)], axis=1)
        here = self.at(times)
        return np.max([np.zeros(len(theta))] + [np.abs(((r.at(times) - here) * d).sum(axis=1)) for r in self.rivals],
                      axis=0)


def _fourier(x: np.ndarray, frequencies: np.ndarray) -> np.ndarray:
    """cos(2π f x) for every f, then sin(2π f x) for f > 0: x [T] rotations -> [T, 2K − 1]."""
    phase = 2 * math.pi * np.outer(x, frequencies)
    return np.concatenate([np.cos(phase), np.sin(phase[:, 1:])], axis=1)


def fit_trajectory(angles: np.ndarray, times: np.ndarray, projections: np.ndarray) -> Trajectory:
    """The smooth centroid trajectory whose projections e(θ_v)·c(t_v) best explain ``projections``.

    angles [V] rad (a gantry turning one way at constant speed), times [V] s, projections [V]
    (`centroid_projections`; NaN views are skipped). Bayesian linear least squares in a Fourier basis
    of period 2·span + MAX_LENGTH rotations, x and y independent a priori, noise white. The evidence
    is maximised over ℓ in [MIN_LENGTH, MAX_LENGTH] and ρ = amplitude / noise in [0.1, MAX_RATIO]
    (the noise in closed form): the best of a grid, refined by Nelder–Mead. ValueError for fewer
    than 3 usable views, or angles or times that do not advance.
    """
    # One BLAS thread: the products are at most a few hundred wide, and threads sharing busy cores
    # made this fit 100x slower (0.34 s -> 40-80 s on the default circle, the same verdicts).
    with threadpool_limits(1):
        return _fit(angles, times, projections)


def _fit(angles: np.ndarray, times: np.ndarray, projections: np.ndarray) -> Trajectory:
    """`fit_trajectory`'s work."""
    angles, times, p = (np.asarray(a, dtype=np.float64).reshape(-1) for a in (angles, times, projections))
    if not angles.shape == times.shape == p.shape:
        raise ValueError(f"angles, times and projections must have one length, got {angles.shape}, {times.shape}, "
                         f"{p.shape}")
    ok = np.isfinite(p) & np.isfinite(angles) & np.isfinite(times)
    if ok.sum() < 3:
        raise ValueError(f"fit_trajectory needs at least 3 views with a centroid, got {int(ok.sum())}")
    angles, times, p = angles[ok], times[ok], p[ok]
    turned = (angles[-1] - angles[0]) / (2 * math.pi)
    if not (turned != 0 and times[-1] > times[0]):
        raise ValueError("fit_trajectory needs views whose angle and time both advance from first to last")
    span = abs(turned)
    rotation_time = (times[-1] - times[0]) / span
    period = 2 * span + MAX_LENGTH
    frequencies = np.arange(math.ceil(CUTOFF / (2 * math.pi * MIN_LENGTH) * period) + 1) / period
    phi = _fourier((times - times[0]) / rotation_time - span / 2, frequencies)
    design = np.concatenate([phi * np.cos(angles)[:, None], phi * np.sin(angles)[:, None]], axis=1)
    evidence = _Evidence(design, p, np.tile(np.concatenate([frequencies, frequencies[1:]]), 2), 1 / period)

    def trajectory(log_scale: float, log_ratio: float) -> Trajectory:
        mean, noise = evidence.posterior(log_scale, log_ratio)
        return Trajectory(float(times[0]), float(rotation_time), float(span), float(angles[0]), float(np.sign(turned)),
                          frequencies, mean.reshape(2, -1).T, math.exp(log_scale), noise,
                          float(np.sqrt(np.mean((design @ mean - p) ** 2))))

    log_scale, log_ratio = evidence.maximise()
    best = trajectory(log_scale, log_ratio)
    rivals = [trajectory(*evidence.maximise(log_scale + side * math.log(RIVAL))) for side in (-1, 1)]
    return replace(best, rivals=tuple(r for r in rivals if r.residual <= (1 + EQUAL) * best.residual))


class _Evidence:
    """The log evidence of projections p [V] = design [V, N] · coefficients + noise, as a function of
    the prior's length scale ℓ and amplitude-to-noise ratio ρ, the noise variance profiled out (its
    maximiser in closed form). Only designᵀdesign, designᵀp and pᵀp enter: O(N³) an evaluation."""

    LENGTHS = (math.log(MIN_LENGTH), math.log(MAX_LENGTH))
    RATIOS = (math.log(0.1), math.log(MAX_RATIO))

    def __init__(self, design: np.ndarray, p: np.ndarray, frequencies: np.ndarray, spacing: float) -> None:
        self.gram, self.moment, self.energy, self.n = design.T @ design, design.T @ p, float(p @ p), len(p)
        self.frequencies, self.spacing = frequencies, spacing

    def _factor(self, log_scale: float, log_ratio: float):
        """(prior sd over noise sd per coefficient [N], Cholesky factor of I + R·gram·R, whitened
        solution [N], noise variance)."""
        scale = math.exp(log_scale)
        r = math.exp(log_ratio) * np.sqrt(math.sqrt(2 * math.pi) * scale * self.spacing) * np.exp(
            -((math.pi * scale * self.frequencies) ** 2))
        chol = cholesky(self.gram * r[:, None] * r[None, :] + np.eye(len(r)), lower=True, check_finite=False)
        # triangular, O(N^2): a general solve by the factor took half of the evidence's time
        z = solve_triangular(chol, r * self.moment, lower=True, check_finite=False)
        return r, chol, z, max(self.energy - float(z @ z), 1e-300) / self.n

    def _negative(self, log_scale: float, log_ratio: float) -> float:
        """−log evidence, up to a constant; +inf where the factor fails."""
        try:
            _, chol, _, variance = self._factor(log_scale, log_ratio)
        except np.linalg.LinAlgError:
            return math.inf
        return 0.5 * self.n * math.log(variance) + float(np.log(np.diag(chol)).sum())

    def maximise(self, log_scale: float | None = None) -> tuple[float, float]:
        """(log ℓ, log ρ) of the largest evidence; with ``log_scale`` given (clipped to the bounds),
        only ρ is chosen. Grid first (12 × 15), then Nelder–Mead or a bounded scalar search."""
        if log_scale is not None:
            log_scale = float(np.clip(log_scale, *self.LENGTHS))
            ratio = minimize_scalar(lambda q: self._negative(log_scale, q), bounds=self.RATIOS, method="bounded")
            return log_scale, float(ratio.x)
        grid = [(a, b) for a in np.linspace(*self.LENGTHS, 12) for b in np.linspace(*self.RATIOS, 15)]
        start = np.array(min(grid, key=lambda q: self._negative(*q)))
        found = minimize(lambda q: self._negative(*q), start, method="Nelder-Mead",
                         bounds=(self.LENGTHS, self.RATIOS), options={"xatol": 1e-3, "fatol": 1e-4})
        q = found.x if found.fun <= self._negative(*start) else start
        return float(q[0]), float(q[1])

    def posterior(self, log_scale: float, log_ratio: float) -> tuple[np.ndarray, float]:
        """Posterior mean of the coefficients [N] and the noise sd."""
        r, chol, z, variance = self._factor(log_scale, log_ratio)
        return r * solve_triangular(chol, z, trans="T", lower=True, check_finite=False), math.sqrt(variance)


@dataclass(frozen=True)
class Determinacy:
    """How well the data fix the motion along the rays: value_px, the largest spread between equally
    good trajectories along the rays over the scan's views (pixels), against threshold_px."""

    value_px: float
    threshold_px: float
    determined: bool
    message: str


def determinacy(trajectory: Trajectory, times: np.ndarray, pixel_size: float,
                threshold_px: float = UNDETERMINED_PX) -> Determinacy:
    """The verdict on ``trajectory`` over the views' ``times`` [V] s with pixels ``pixel_size`` wide
    (the image's extent / size); see benchmarks/results/trajectory for what it reads on the circle."""
    if not (pixel_size > 0 and threshold_px > 0):
        raise ValueError(f"pixel_size and threshold_px must be > 0, got {pixel_size}, {threshold_px}")
    value = float(trajectory.ray_spread(times).max()) / pixel_size
    if value <= threshold_px:
        return Determinacy(value, threshold_px, True, f"motion along the rays determined to {value:.2f} px")
    return Determinacy(value, threshold_px, False,
                       f"motion along the rays undetermined ({value:.1f} px > {threshold_px:g} px between equally "
                       "good fits): more rotations or a motion prior needed")
