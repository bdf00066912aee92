"""FBP frames of one moving object with its translation undone (issue 27, item 3).

A lone object's mass centroid c(t) is read off the views' first moments (trajectory.py): each
view v sees it at e(θ_v)·c(t_v) on the detector. Shifting every view by that amount gives the
views of the object held at the origin, exactly for a translating rigid object; their FBP over a
window is sharp however fast it moves (a deformation still smears as before; a turn read off the
views' second moments is undone too), and moved to c(t_f) it is the frame at t_f. Plain FBP frames
of the circle at 200°/rotation smear the disc over 100° of its orbit: the InitFit start a fit then
has to undo, and a moved template started from it settled on a gantry-locked ellipse that explains
the views as well as the disc.

Over a static background the whole mass's centroid moves by the mover's share of the mass times
the mover's own motion: the mover's path is c(t) scaled about its mean, by the factor that brings
the views minus the background's start into focus (`focused_path`).
"""

from __future__ import annotations

import warnings
from dataclasses import replace

import numpy as np
from scipy.ndimage import label, map_coordinates, shift
from scipy.optimize import minimize_scalar

from nct.acquisition.rebin import to_parallel
from nct.acquisition.scanner import ImageGrid
from nct.acquisition.sinogram import Sinogram
from nct.moments.orientation import Orientation
from nct.moments.trajectory import Trajectory
from nct.physics.fbp import fbp_frames

# Scales tried for a mover over a static background (the whole mass over the mover's), then refined
# between the best one's neighbours: a mover down to 1/64 of the mass (the vessel: 1/13).
FOCUS_SCALES = np.geomspace(1.0, 64.0, 13)


def centred_views(sino: Sinogram, path: Trajectory) -> Sinogram:
    """``sino`` rebinned to parallel rays, each view shifted by −e(θ)·c(t) along its detector: the
    views the object would give held with its centroid at the origin. [V, n_bins] float32."""
    sino = to_parallel(sino)
    theta = np.asarray(sino.angles, dtype=np.float64)
    centre = path.at(np.asarray(sino.times, dtype=np.float64))  # [V, 2]
    along = centre[:, 0] * np.cos(theta) + centre[:, 1] * np.sin(theta)  # [V]
    bins = sino.geometry.bin_positions
    index = (bins[None, :] + along[:, None] - bins[0]) / sino.geometry.bin_spacing  # p~(u) = p(u + e·c)
    rows = np.broadcast_to(np.arange(len(theta))[:, None], index.shape)
    values = map_coordinates(np.asarray(sino.values, dtype=np.float64), [rows, index], order=1, mode="constant")
    return replace(sino, values=values.astype(np.float32))


def compensated_frames(sino: Sinogram, path: Trajectory, grid: ImageGrid, times: np.ndarray,
                       window_deg: float, filter: str, axis: Orientation | None = None) -> np.ndarray:
    """FBP frames [F, H, W] at ``times`` [F] (``sino``'s clock) of the views centred on ``path``,
    each moved back to where ``path`` puts the object at its time (bilinear). With the object's
    ``axis`` (orientation.py) its turn is undone too: a parallel view at θ of the object turned by
    φ(t) about its centroid is a view at θ − φ(t) of the object unturned (`turned_views`)."""
    times = np.asarray(times, dtype=np.float64)
    centre = path.at(times)  # [F, 2], x right, y up
    centred = centred_views(sino, path)
    held_at = None if axis is None else float(np.mean(axis.at(np.asarray(centred.times, dtype=np.float64))))
    turned = None if axis is None else turned_views(centred, axis, held_at)
    if turned is None:
        frames = fbp_frames(centred, grid, times, window_deg, filter)
        return np.stack([shift(frame, (-cy / grid.pixel_size, cx / grid.pixel_size), order=1, mode="constant")
                         for frame, (cx, cy) in zip(frames, centre)])
    with warnings.catch_warnings():  # a frame seen over less than the window: the run's turn_warnings say so
        warnings.filterwarnings("ignore", message="the acquisition covers")
        frames = fbp_frames(turned, grid, times, window_deg, filter)
    turn = axis.at(times) - held_at
    x, y = grid.xy()
    middle = (grid.size - 1) / 2
    moved = []
    for frame, (cx, cy), phi in zip(frames, centre, turn):
        dx, dy = x - cx, y - cy
        qx, qy = np.cos(phi) * dx + np.sin(phi) * dy, np.cos(phi) * dy - np.sin(phi) * dx  # R(-phi)(x - c)
        where = [middle - qy / grid.pixel_size, middle + qx / grid.pixel_size]  # rows run down, y up
        moved.append(map_coordinates(frame, where, order=1, mode="constant"))
    return np.stack(moved)


def turned_views(centred: Sinogram, axis: Orientation, held_at: float) -> Sinogram | None:
    """Centred parallel views relabelled to the angles θ − (φ(t) − ``held_at``) at which the object,
    held at that axis (rad), gives them; None where those angles do not advance one way (it turns as
    fast as the gantry: then no window of them covers half a turn)."""
    relabelled = np.asarray(centred.angles, dtype=np.float64) - (axis.at(centred.times) - held_at)
    steps = np.diff(relabelled)
    if not (np.all(steps > 0) or np.all(steps < 0)):
        return None
    return replace(centred, angles=relabelled)


def focused_path(residual: Sinogram, total: Trajectory, grid: ImageGrid) -> tuple[Trajectory, float]:
    """The path of one mover over a static background: the whole mass's centroid path ``total``
    scaled about its mean by the factor whose centred views of ``residual`` (the views minus the
    background's start: the mover and a static remainder) give the FBP of largest energy, sum of
    squares over one rotation's window at each rotation's middle: the mover in focus, the remainder
    smeared. It starts where the focused mover sits (the centroid of its largest piece above half
    the image's peak). In the units of ``residual`` (times, lengths); also the scale."""
    residual = to_parallel(residual)  # once, not at every scale tried
    times = np.asarray(residual.times, dtype=np.float64)
    mean = total.at(times).mean(axis=0)
    turns = max(1, round(float(total.span)))
    middles = times[0] + (np.arange(turns) + 0.5) * (times[-1] - times[0]) / turns

    def image(scale: float) -> np.ndarray:
        centred = centred_views(residual, total.scaled(scale, mean, np.zeros(2)))
        return fbp_frames(centred, grid, middles, 360.0, "ramp").mean(axis=0)

    def energy(scale: float) -> float:
        return float(np.square(image(scale)).sum())

    best = int(np.argmax([energy(k) for k in FOCUS_SCALES]))
    low, high = FOCUS_SCALES[max(best - 1, 0)], FOCUS_SCALES[min(best + 1, len(FOCUS_SCALES) - 1)]
    scale = float(minimize_scalar(lambda k: -energy(k), bounds=(low, high), method="bounded",
                                  options={"xatol": 0.01}).x)
    focused = image(scale)
    pieces, _ = label(focused > 0.5 * focused.max())
    largest = pieces == 1 + int(np.argmax(np.bincount(pieces.ravel())[1:]))
    x, y = grid.xy()
    return total.scaled(scale, mean, np.array([x[largest].mean(), y[largest].mean()])), scale
