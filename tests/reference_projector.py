"""An independent reference projector for the tests: exact ray–pixel intersection lengths (Siddon's
method) of a pixel image, along rays whose end points are derived here from the documented convention
(README "Sinogram file", ``shared/DESIGN.md`` "Geometry convention"), not from ``nct.acquisition.geometry``.

Convention: a point (x, y), x right, y up, origin at the image centre; pixel (row, col) of N covers
x in [col, col + 1]·extent/N − extent/2 and y in [N − row − 1, N − row]·extent/N − extent/2. At view
angle θ, d = (−sin θ, cos θ), e = (cos θ, sin θ); bin i at u_i = (i − (n − 1)/2)·bin_spacing + offset.
Parallel: the ray through u·e along d. Fan: from the source −D·d to the flat detector point
D_d·d + u·e, or on the curved detector at fan angle γ = u/(D + D_d) from the central ray, i.e. the
point −D·d + (D + D_d)(cos γ·d + sin γ·e).
"""

from __future__ import annotations

import numpy as np


def ray_end_points(theta: np.ndarray, u: np.ndarray, source_distance: float | None = None,
                   detector_distance: float | None = None, detector_shape: str = "flat",
                   reach: float = 10.0) -> tuple[np.ndarray, np.ndarray]:
    """Start and end points of every ray, ([V, B, 2], [V, B, 2]): parallel rays (no ``source_distance``)
    run from u·e − reach·d to u·e + reach·d; fan rays from the source to the detector."""
    d = np.stack((-np.sin(theta), np.cos(theta)), -1)[:, None, :]
    e = np.stack((np.cos(theta), np.sin(theta)), -1)[:, None, :]
    u = np.asarray(u, dtype=np.float64)[None, :, None]
    if source_distance is None:
        return u * e - reach * d, u * e + reach * d
    source = -source_distance * d + 0 * u
    if detector_shape == "flat":
        return source, detector_distance * d + u * e
    gamma = u / (source_distance + detector_distance)
    return source, source + (source_distance + detector_distance) * (np.cos(gamma) * d + np.sin(gamma) * e)


def siddon(image: np.ndarray, extent: float, start: np.ndarray, end: np.ndarray) -> np.ndarray:
    """Line integrals of the piecewise-constant ``image`` [N, N] (side ``extent``) along the segments
    start -> end ([..., 2] each): the sum over pixels of value × exact length of the segment inside it."""
    n = image.shape[0]
    shape = start.shape[:-1]
    p1, p2 = start.reshape(-1, 2), end.reshape(-1, 2)
    delta = p2 - p1
    planes = np.linspace(-extent / 2, extent / 2, n + 1)
    # Parameters α in [0, 1] where the segment crosses every vertical and horizontal pixel boundary.
    with np.errstate(divide="ignore", invalid="ignore"):
        crossings = [(planes[None, :] - p1[:, k : k + 1]) / delta[:, k : k + 1] for k in (0, 1)]
    alphas = np.concatenate([np.zeros((len(p1), 1)), np.ones((len(p1), 1)), *crossings], axis=1)
    alphas = np.sort(np.clip(np.nan_to_num(alphas, nan=0.0, posinf=0.0, neginf=0.0), 0.0, 1.0), axis=1)
    lengths = np.diff(alphas, axis=1) * np.linalg.norm(delta, axis=1)[:, None]
    middle = p1[:, None, :] + 0.5 * (alphas[:, 1:] + alphas[:, :-1])[..., None] * delta[:, None, :]
    pixel = extent / n
    col = np.floor((middle[..., 0] + extent / 2) / pixel).astype(int)
    row = np.floor((extent / 2 - middle[..., 1]) / pixel).astype(int)
    inside = (col >= 0) & (col < n) & (row >= 0) & (row < n) & (lengths > 0)
    values = np.where(inside, image[row.clip(0, n - 1), col.clip(0, n - 1)], 0.0)
    return (values * lengths).sum(axis=1).reshape(shape)
