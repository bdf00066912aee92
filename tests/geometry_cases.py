"""Shared by the geometry tests: every geometry the projector, simulation and FBP must handle, and
the closed-form line integrals of ellipses along their rays, derived from the convention in
``shared/DESIGN.md`` independently of ``nct.acquisition.geometry``."""

from __future__ import annotations

import numpy as np

from nct.acquisition.geometry import FanGeometry, ParallelGeometry
from nct.acquisition.scanner import ImageGrid

# Objects stay within radius 0.5 of a unit field of view; every detector sees all of that disc.
GEOMETRIES = {
    "parallel": ParallelGeometry(96, 1 / 64),
    "parallel-offset": ParallelGeometry(104, 1 / 64, detector_offset=0.06),
    "fan-flat": FanGeometry(128, 0.0125, source_distance=2.0, detector_distance=1.0),
    "fan-curved": FanGeometry(128, 0.0125, source_distance=2.0, detector_distance=1.0, detector_shape="curved"),
    "fan-flat-offset": FanGeometry(144, 0.0125, 2.0, 1.0, "flat", detector_offset=0.1),
    "fan-curved-offset": FanGeometry(144, 0.0125, 2.0, 1.0, "curved", detector_offset=-0.1),
}

# (cx, cy, semi-axis a along direction phi, semi-axis b, phi, intensity): off-centre and rotated.
ELLIPSES = ((0.1, -0.05, 0.32, 0.22, 0.5, 1.0), (-0.18, 0.12, 0.1, 0.06, -0.4, 0.5))


def detector_u(geometry, n_bins: int | None = None) -> np.ndarray:
    """u_i = (i - (n_bins - 1)/2) bin_spacing + detector_offset: [n_bins]."""
    n = geometry.n_bins if n_bins is None else n_bins
    return (np.arange(n) - (n - 1) / 2) * geometry.bin_spacing + geometry.detector_offset


def reference_rays(geometry, angles: np.ndarray, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A point on each ray and its unit direction, [V, B, 2] each, straight from the convention:
    parallel rays run along d through u e; fan rays leave the source -D d towards the flat detector
    point Dd d + u e, or at fan angle u / (D + Dd) on the curved one."""
    d = np.stack((-np.sin(angles), np.cos(angles)), -1)[:, None, :]
    e = np.stack((np.cos(angles), np.sin(angles)), -1)[:, None, :]
    u = u[None, :, None]
    if isinstance(geometry, ParallelGeometry):
        return u * e + 0 * d, d + 0 * u
    source = -geometry.source_distance * d + 0 * u
    if geometry.detector_shape == "flat":
        towards = geometry.detector_distance * d + u * e - source
    else:
        gamma = u / (geometry.source_distance + geometry.detector_distance)
        towards = np.cos(gamma) * d + np.sin(gamma) * e
    return source, towards / np.linalg.norm(towards, axis=-1, keepdims=True)


def ellipse_chords(points: np.ndarray, directions: np.ndarray, ellipses) -> np.ndarray:
    """Line integrals of filled ellipses along the lines p + t v ([..., 2] each): [...].

    In each ellipse's frame, |q + t w|_ellipse = 1 is A t^2 + B t + C = 0; the chord is sqrt(B^2 - 4AC) / A.
    """
    total = np.zeros(points.shape[:-1])
    for cx, cy, a, b, phi, value in ellipses:
        c, s = np.cos(phi), np.sin(phi)
        qx, qy = points[..., 0] - cx, points[..., 1] - cy
        q = ((qx * c + qy * s) / a, (-qx * s + qy * c) / b)
        vx, vy = directions[..., 0], directions[..., 1]
        w = ((vx * c + vy * s) / a, (-vx * s + vy * c) / b)
        A = w[0] ** 2 + w[1] ** 2
        B = 2 * (q[0] * w[0] + q[1] * w[1])
        C = q[0] ** 2 + q[1] ** 2 - 1
        total += value * np.sqrt(np.clip(B * B - 4 * A * C, 0, None)) / A
    return total


def closed_form_sinogram(geometry, angles: np.ndarray, ellipses=ELLIPSES, sub_rays: int = 1) -> np.ndarray:
    """Closed-form line integrals averaged over ``sub_rays`` rays evenly across each bin: [V, n_bins]."""
    offsets = ((np.arange(sub_rays) + 0.5) / sub_rays - 0.5) * geometry.bin_spacing
    u = (detector_u(geometry)[:, None] + offsets[None, :]).reshape(-1)
    chords = ellipse_chords(*reference_rays(geometry, angles, u), ellipses)
    return chords.reshape(len(angles), geometry.n_bins, sub_rays).mean(axis=-1)


def ellipse_image(grid: ImageGrid, ellipses=ELLIPSES, supersample: int = 8) -> np.ndarray:
    """Area-averaged intensity of filled ellipses on ``grid``: [H, W] float64."""
    x, y = grid.refined(supersample).xy()
    fine = np.zeros_like(x)
    for cx, cy, a, b, phi, value in ellipses:
        along = (x - cx) * np.cos(phi) + (y - cy) * np.sin(phi)
        across = -(x - cx) * np.sin(phi) + (y - cy) * np.cos(phi)
        fine += value * ((along / a) ** 2 + (across / b) ** 2 <= 1)
    n = grid.size
    return fine.reshape(n, supersample, n, supersample).mean(axis=(1, 3))


def rel_l2(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.linalg.norm(a - b) / np.linalg.norm(b))
