"""A static background under the moving objects (``background=image``; issue 29).

The image is mu(x, t) = b(x) + sum_k a(k) zeta_k(x, t): b a pixel image on the grid, fitted with the
objects (TV-regularised), the K objects the parts that move. Where the FBP frames change over the scan
is the moving region; b starts from the frames' mean with that region filled in from its
surroundings, and the objects are found (init/segmentation.py) in what then remains:
the frames minus b's start, inside the region, and the views minus b's projection. One object
over b is held to the path that its motion leaves in the views' first moments (`lone_mover`).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, replace

import numpy as np
import torch
from scipy.ndimage import binary_dilation, label

from nct.fit.problem import Problem
from nct.init.segmentation import fill_holes
from nct.moments.compensation import compensated_frames, focused_path
from nct.moments.trajectory import centroid_path, steady_mass, view_masses
from nct.physics.projector import project

log = logging.getLogger(__name__)

WIDEN_PX = 2  # the region grows by this many pixels: its rule finds a moving edge's core, not its ramp
PERCENTILE = 99.9  # moving_share is a share of the temporal std at this percentile (the maximum is one pixel's)
# A still scene's frames differ by noise and discretisation alone: a pixel moves only where its std
# over time is also this many times the median pixel's (noise) and this share of the frames' peak.
NOISE_FACTOR = 3.0
PEAK_SHARE = 0.02
# A slow mover's middle never changes: only its leading and trailing edges do (holes000: two slivers
# of 13 and 8 px). Its middle stays at its own level, so the region also takes what lies, on average
# over the scan, above the level between an edge's brightest and what it shows when uncovered. A body
# is a large share of the field (the textured scenes' 20 % and more), a mover's middle a small one
# (holes000's 1.6 %): a still part larger than MIDDLE_SHARE of the field is a body, not a middle, and
# stays out. No benchmark scene has such a part (their regions are the same without the bound); a
# still block as bright as a mover and touching it has (tests/init/test_background.py).
MIDDLE_SHARE = 0.1
EDGE_PERCENTILE = 90  # an edge's brightest over time: this percentile of its pixels' maxima (not one pixel's)


@dataclass(frozen=True)
class StaticStart:
    """Where a static background starts: ``image`` [H, W] (method units) and the ``moving`` region [H, W] bool."""

    image: np.ndarray
    moving: np.ndarray


def moving_region(frames: np.ndarray, share: float) -> np.ndarray:
    """Pixels of FBP ``frames`` [F, H, W] whose std over time exceeds ``share`` of its
    PERCENTILE-th percentile (and the still scene's floors), with each piece's still middle
    (`still_middles`), widened by WIDEN_PX and with holes filled (an object's still middle moves
    with it): [H, W] bool, empty for a still scene."""
    spread = frames.std(axis=0)
    edges = spread > edge_threshold(frames, spread, share)
    return fill_holes(binary_dilation(edges | still_middles(frames, edges), iterations=WIDEN_PX))


def edge_threshold(frames: np.ndarray, spread: np.ndarray, share: float) -> float:
    """The spread over time [H, W] of FBP ``frames`` [F, H, W] above which a pixel moves: ``share`` of its
    PERCENTILE-th percentile, and at least `still_floor`."""
    return max(share * float(np.percentile(spread, PERCENTILE)), still_floor(frames, spread))


def still_middles(frames: np.ndarray, edges: np.ndarray) -> np.ndarray:
    """The still middles [H, W] bool of the movers whose moving ``edges`` [H, W] bool FBP ``frames``
    [F, H, W] show: for each piece of the edges, the connected parts it touches whose mean over time
    is above the piece's level (halfway between its brightest, EDGE_PERCENTILE of its maxima over
    time, and the median of its minima, what it shows uncovered), each no larger than MIDDLE_SHARE
    of the field. The mean, not the minimum: a middle's rim is uncovered in a frame or two."""
    lowest, highest, mean = frames.min(axis=0), frames.max(axis=0), frames.mean(axis=0)
    middles = np.zeros(edges.shape, bool)
    pieces, n = label(edges)
    for piece in range(1, n + 1):
        inside = pieces == piece
        level = 0.5 * (np.percentile(highest[inside], EDGE_PERCENTILE) + np.median(lowest[inside]))
        parts, _ = label(mean >= level)
        for part in np.unique(parts[binary_dilation(inside)]):
            if part == 0:  # what lies below the level
                continue
            candidate = parts == part
            if candidate.sum() <= MIDDLE_SHARE * candidate.size:
                middles |= candidate
    return middles


def still_floor(frames: np.ndarray, spread: np.ndarray) -> float:
    """The spread over time [H, W] of FBP ``frames`` [F, H, W] below which a pixel is still, whatever
    ``moving_share``: NOISE_FACTOR times the median pixel's and PEAK_SHARE of the frames' peak."""
    return max(NOISE_FACTOR * float(np.median(spread)), PEAK_SHARE * float(np.abs(frames).max()))


def static_start(frames: np.ndarray, share: float) -> StaticStart:
    """The background's start from FBP ``frames`` [F, H, W]: their mean, each connected piece of the
    moving region filled with the median of the pixels around it (a biharmonic or linear fill
    overshoots, or carries a neighbouring lung's level into the heart)."""
    moving = moving_region(frames, share)
    image = frames.mean(axis=0)
    pieces, n = label(moving)
    for piece in range(1, n + 1):
        inside = pieces == piece
        ring = binary_dilation(inside, iterations=WIDEN_PX) & ~moving
        if ring.any():
            image[inside] = np.median(image[ring])
    return StaticStart(image.astype(np.float32), moving)


def moving_problem(prob: Problem, start: StaticStart) -> Problem:
    """``prob`` as the objects alone see it: FBP frames minus the background inside the moving region
    (zero elsewhere), views minus the background's projection."""
    frames = (prob.fbp - start.image) * start.moving
    views = prob.views
    shown = project(torch.from_numpy(start.image), views.angles, views.geometry, prob.grid.extent)
    return replace(prob, fbp=frames.astype(np.float32), views=replace(views, values=views.values - shown))


def lone_mover(prob: Problem, moved: Problem, moving: np.ndarray) -> Problem:
    """``moved`` (`moving_problem` of ``prob``) for one object over the background: its ``centres``
    at the init times and FBP frames of its views with its translation undone (moments/compensation.py),
    inside the ``moving`` region [H, W]. Its path is the whole mass's centroid path, read off
    ``prob``'s fitted views, scaled into focus on ``moved``'s (compensate.focused_path): the plain
    frames smear a small mover and their centroids lag its motion, by pixels at the scan's ends.
    ``moved`` as it was where the views' total mass is not steady against the mover's (the residual
    views' mass; trajectory.steady_mass): then something else moves too, the centroid's path not the
    mover's; and in fan beam, whose views give no path (trajectory.centroid_path)."""
    total, residual = prob.fitted_sinogram(), moved.fitted_sinogram()
    if not steady_mass(total, float(np.median(view_masses(residual)))):
        log.info("one object over the background: the views' mass changes by a tenth of its own or more: something "
                 "else moves too, and it starts from the FBP frames")
        return moved
    total_path = centroid_path(total)
    if total_path is None:
        log.info("one object over the background: fan beam gives no path to hold it to (trajectory.centroid_path); "
                 "it starts from the FBP frames")
        return moved
    path, scale = focused_path(residual, total_path, prob.grid)
    log.info("one object over the background: its path is the mass centroid's scaled %.3g times into focus", scale)
    times = prob.init_times.double().numpy()
    frames = compensated_frames(residual, path, prob.grid, times, prob.fbp_window_deg, prob.fbp_filter) * moving
    return replace(moved, fbp=frames.astype(np.float32),
                   centres=(path.at(times) * 2 / prob.grid.extent).astype(np.float32))
