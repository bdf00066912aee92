"""Rebinning onto parallel rays: any geometry's sinogram as a centred parallel-beam sinogram.

Every ray is a line (φ, σ) (``geometry.py``); a parallel view at angle φ needs, for each offset σ,
the measurement of that line: at view angle θ and detector coordinate u given by
``geometry.locate``, or, half a turn away, by ``locate(φ ± π, −σ)``. Of those inside the
acquired angles the one nearest in angle (so in time) is interpolated bilinearly in (view, bin).
The parallel views keep the original views' angles and times, so FBP windows by time and
angle (`physics/fbp.py` `fbp_frames`) work unchanged, and a short scan (180° plus the fan angle) gives
complete 180° windows without redundancy weights.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.ndimage import map_coordinates

from nct.acquisition.geometry import Geometry, ParallelGeometry
from nct.acquisition.sinogram import Sinogram


def parallel_geometry_for(geometry: Geometry) -> ParallelGeometry:
    """The centred parallel detector that rebinning fills: the pitch of ``geometry``'s rays at the axis,
    wide enough for every ray it measures."""
    spacing = geometry.bin_spacing / geometry.magnification
    return ParallelGeometry(2 * math.ceil(geometry.field_radius / spacing), spacing)


def to_parallel(sino: Sinogram) -> Sinogram:
    """``sino`` on the rays of `parallel_geometry_for` its geometry, views and times kept: [V, n_bins'] float32.

    A centred parallel sinogram comes back as it is. Lines the acquisition never measured (at its
    first and last views, when it covers less than a turn plus the fan angle) take the nearest view.
    """
    geometry = sino.geometry
    if geometry.is_parallel and geometry.detector_offset == 0:
        return sino
    target = parallel_geometry_for(geometry)
    theta = _monotonic(np.unwrap(np.asarray(sino.angles, dtype=np.float64)))
    order = np.argsort(theta)
    phi, sigma = np.broadcast_arrays(*target.lines(theta, target.bin_positions))
    candidates = [geometry.locate(phi, sigma), geometry.locate(phi + math.pi, -sigma),
                  geometry.locate(phi - math.pi, -sigma)]
    views = np.stack([c[0] for c in candidates])
    u = np.stack([c[1] for c in candidates])
    outside = np.maximum(theta.min() - views, views - theta.max()).clip(min=0)
    # Inside the acquisition first (in-range ranks are < 2 tau), then nearest in angle to the parallel view.
    rank = np.where(outside > 0, 2 * math.tau + outside, np.abs(views - phi))
    best = np.argmin(rank, axis=0)[None]
    view_index = np.interp(np.take_along_axis(views, best, 0)[0], theta[order], order)
    bin_index = (np.take_along_axis(u, best, 0)[0] - geometry.bin_positions[0]) / geometry.bin_spacing
    values = map_coordinates(np.asarray(sino.values, dtype=np.float64), [view_index, bin_index], order=1,
                             mode="constant", cval=0.0)
    return Sinogram(values.astype(np.float32), sino.angles, sino.times, target, truth=sino.truth)


def _monotonic(theta: np.ndarray) -> np.ndarray:
    """Unwrapped view angles, required strictly monotonic (the gantry turns one way): [V]."""
    steps = np.diff(theta)
    if theta.ndim != 1 or theta.size < 2 or not (np.all(steps > 0) or np.all(steps < 0)):
        raise ValueError("rebinning needs at least two views with strictly monotonic angles")
    return theta
