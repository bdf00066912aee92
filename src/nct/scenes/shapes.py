"""How a scene is imaged and projected: the `Phantom` interface, and ellipses with closed-form
projections (glyphs, rasterised finely: ``letters.py``).

Detector model (all scenes): a bin's value is the mean line integral over the bin's width (box
aperture), every view at its own instant, along the scanner geometry's rays (parallel or fan
beam). Ellipses (of uniform intensity, or graded: a linear gradient across them) use the exact
integral of their closed-form chord integral (in fan beam over the strip of lines at the bin's
centre-ray angle between the ray offsets of its edges: within 1e-3 of the mean over the bin's fan
of rays); other scenes are rasterised 4x finer than the grid and projected pixel-driven
(``letters.py``). Lengths here are physical (``grid.extent``); the scenes' configs and `build_phantom`
are in ``phantoms.py``.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable

import numpy as np

from nct.acquisition.scanner import ImageGrid, Scanner

EllipseParams = Callable[[np.ndarray], np.ndarray]  # τ (rotations) [T] -> [T, K, 6]: see `EllipsePhantom`
EllipseGradients = Callable[[np.ndarray], np.ndarray]  # τ (rotations) [T] -> [T, K, 2]: see `EllipsePhantom`


class Phantom(ABC):
    """A time-varying scene. ``intensities``: one per object (K = len); times in seconds."""

    intensities: tuple[float, ...]
    rotation_time: float

    @abstractmethod
    def image(self, t: float, grid: ImageGrid, supersample: int = 4) -> np.ndarray:
        """Intensity at time ``t``, area-averaged over supersample² sub-pixels: [H, W] float32."""

    def frames(self, times: np.ndarray, grid: ImageGrid, supersample: int = 4) -> np.ndarray:
        """`image` at each of ``times`` [F]: [F, H, W] float32."""
        return np.stack([self.image(float(t), grid, supersample) for t in np.asarray(times)])

    @abstractmethod
    def project(self, scanner: Scanner, grid: ImageGrid) -> np.ndarray:
        """Line integrals of every view at its own time: [n_views, n_bins] float32."""

    def levels(self, times: np.ndarray) -> tuple[float, ...]:
        """Each object's own Dice level over ``times`` (s) [T]: its container's intensity plus half its
        own; here half its own (objects on an empty background, apart). One per object (K)."""
        return tuple(0.5 * i for i in self.intensities)


def block_mean(fine: np.ndarray, factor: int) -> np.ndarray:
    """Average ``factor`` x ``factor`` blocks: [H*f, W*f] -> [H, W] float32."""
    h, w = fine.shape[0] // factor, fine.shape[1] // factor
    return fine.reshape(h, factor, w, factor).mean(axis=(1, 3)).astype(np.float32)


def check_supersample(supersample: int) -> None:
    """Refuse a ``supersample`` that is not an integer >= 1."""
    if int(supersample) != supersample or supersample < 1:
        raise ValueError(f"supersample must be an integer >= 1, got {supersample}")


class EllipsePhantom(Phantom):
    """A sum of moving ellipses with exact (closed-form) projections; overlapping ellipses add.

    ``params``: τ (rotations) [T] -> [T, K, 6] columns x, y, a, b (FOV fractions), angle (rad,
    counter-clockwise), intensity (at the centre). ``gradients`` (None: none): τ [T] -> [T, K, 2],
    the intensity's change per FOV side along x and y, so that an ellipse holds
    intensity + g·(p − centre) at each of its points p.
    """

    def __init__(self, params: EllipseParams, intensities: tuple[float, ...], rotation_time: float,
                 gradients: EllipseGradients | None = None) -> None:
        self._params = params
        self._gradients = gradients
        self.intensities = intensities
        self.rotation_time = rotation_time

    def ellipses(self, times: np.ndarray, extent: float = 1.0) -> np.ndarray:
        """Ellipse parameters at ``times`` (s) [T] with lengths scaled by ``extent``: [T, K, 6]."""
        p = self._params(np.asarray(times, dtype=np.float64) / self.rotation_time)
        p[..., :4] *= extent
        return p

    def gradients(self, times: np.ndarray, extent: float = 1.0) -> np.ndarray:
        """Each ellipse's intensity gradient (x, y) per length unit of a FOV ``extent`` a side: [T, K, 2]."""
        tau = np.atleast_1d(np.asarray(times, dtype=np.float64)) / self.rotation_time
        if self._gradients is None:
            return np.zeros((len(tau), len(self.intensities), 2))
        return self._gradients(tau) / extent

    def values(self, times: np.ndarray, x: np.ndarray, y: np.ndarray, extent: float = 1.0) -> np.ndarray:
        """The scene's intensity at points (x, y) [...] of a FOV ``extent`` a side at ``times`` (s) [T]: [T, ...]."""
        params, grads = self.ellipses(times, extent), self.gradients(times, extent)  # [T, K, 6], [T, K, 2]
        out = np.zeros(params.shape[:1] + np.shape(x))
        for j in range(params.shape[1]):
            out += _ellipse_values(*(p[:, j].T.reshape(p.shape[-1], -1, *[1] * np.ndim(x)) for p in (params, grads)),
                                   x, y)
        return out

    def image(self, t: float, grid: ImageGrid, supersample: int = 4) -> np.ndarray:
        check_supersample(supersample)
        x, y = grid.refined(supersample).xy()
        return block_mean(self.values(np.array([t]), x, y, grid.extent)[0], supersample)

    def levels(self, times: np.ndarray) -> tuple[float, ...]:
        """Object k's own level: the summed intensity at its centre of the larger ellipses (its
        container; the smaller ones lie on it) plus half its own intensity, the median over ``times`` [T]."""
        params, grads = self.ellipses(times), self.gradients(times)  # [T, K, 6], [T, K, 2]
        x, y, area = params[:, :, 0], params[:, :, 1], params[:, :, 2] * params[:, :, 3]  # [T, K] each
        container = np.zeros_like(x)
        for j in range(params.shape[1]):  # ellipse j's intensity at every centre, where j is the larger
            at_centres = _ellipse_values(params[:, j].T[:, :, None], grads[:, j].T[:, :, None], x, y)
            container += np.where(area[:, j, None] > area, at_centres, 0.0)
        return tuple(float(v) for v in np.median(container + 0.5 * params[:, :, 5], axis=0))

    def project(self, scanner: Scanner, grid: ImageGrid) -> np.ndarray:
        """Exact mean over each bin of the chord integral along the scanner's rays. A line (φ, σ)
        (``geometry.py``'s normal form) at σ' = σ − (x cos φ + y sin φ) from the centre cuts a chord
        of length 2ab·sqrt(h² − σ'²)/h², h² = a²cos²φ' + b²sin²φ', φ' = φ − angle, whose midpoint is
        σ'·Mn/h² from the centre (M = R diag(a², b²) Rᵀ, n = (cos φ, sin φ)): a linear intensity
        integrates to the chord length times its value there. A bin is the strip of lines at its
        centre ray's φ between the σ of its edges: in parallel beam exactly the bin; in fan beam it
        neglects the bin's angular width."""
        geometry = scanner.geometry
        phi, _ = geometry.lines(scanner.angles, geometry.bin_positions)
        _, edges = geometry.lines(scanner.angles, geometry.bin_edges)
        phi = np.broadcast_to(phi, (scanner.n_views, scanner.n_bins))
        edges = np.broadcast_to(edges, (scanner.n_views, scanner.n_bins + 1))
        sino = np.zeros((scanner.n_views, scanner.n_bins))
        params = self.ellipses(scanner.times, grid.extent).transpose(1, 2, 0)
        grads = self.gradients(scanner.times, grid.extent).transpose(1, 2, 0)
        for obj, grad in zip(params, grads):
            cx, cy, a, b, angle, intensity = obj[:, :, None]
            h = np.sqrt((a * np.cos(phi - angle)) ** 2 + (b * np.sin(phi - angle)) ** 2)
            centre = cx * np.cos(phi) + cy * np.sin(phi)
            lo, hi = (np.clip(side - centre, -h, h) for side in (edges[:, :-1], edges[:, 1:]))
            area = (_chord_antiderivative(hi, h) - _chord_antiderivative(lo, h)) * a * b / (h * h)
            sino += intensity * area / np.diff(edges, axis=1)
            if grad.any():
                gx, gy = grad[:, :, None]
                cos, sin = np.cos(phi - angle), np.sin(phi - angle)
                along = gx * (a * a * cos * np.cos(angle) - b * b * sin * np.sin(angle))  # g·Mn
                along += gy * (a * a * cos * np.sin(angle) + b * b * sin * np.cos(angle))
                moment = (_moment_antiderivative(hi, h) - _moment_antiderivative(lo, h)) * a * b / (h * h)
                sino += along / (h * h) * moment / np.diff(edges, axis=1)
        return sino.astype(np.float32)


def _ellipse_values(params: np.ndarray, grads: np.ndarray, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """One ellipse's intensity at points (x, y) [...] (0 outside it); params (x, y, a, b, angle,
    intensity) [6, ...] and grads (x, y) [2, ...] broadcast against the points."""
    cx, cy, a, b, angle, intensity = params
    dx, dy = x - cx, y - cy
    u = (dx * np.cos(angle) + dy * np.sin(angle)) / a
    v = (-dx * np.sin(angle) + dy * np.cos(angle)) / b
    return (intensity + grads[0] * dx + grads[1] * dy) * (u * u + v * v <= 1.0)


def _chord_antiderivative(s: np.ndarray, h: np.ndarray) -> np.ndarray:
    """∫ 2·sqrt(h² − s²) ds (up to a constant), for |s| <= h: the area under a unit disc's chords."""
    return s * np.sqrt(np.maximum(h * h - s * s, 0.0)) + h * h * np.arcsin(s / h)


def _moment_antiderivative(s: np.ndarray, h: np.ndarray) -> np.ndarray:
    """∫ s·2·sqrt(h² − s²) ds (up to a constant), for |s| <= h: the chords' first moment."""
    return -2.0 / 3.0 * np.maximum(h * h - s * s, 0.0) ** 1.5

