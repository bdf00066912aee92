"""Where fits start (Algorithms 1-2): segmentations of the FBP frames, each as SDF frames InitFit fits.

With several objects, a segmentation can hand an object to the background or split one in two, and
a fit cannot create an object no field starts on: the judge's ``init.starts`` best segmentations
are all offered to the tournament (select/tournament.py). One object starts on the brightest structure whichever
segmentation wins, and the fit moves its boundary, so one start is enough there.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, replace

import numpy as np
import torch

from nct.fields.sightings import Sightings, mask_sightings
from nct.fit.problem import Problem
from nct.fit.session import Start
from nct.init.background import lone_mover, moving_problem, static_start
from nct.init.conf import BackgroundConf, InitConf
from nct.init.judge import sinogram_judge
from nct.init.sdf import masks_to_sdf
from nct.init.segmentation import Judge, Segmentation, segmentations

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class Found:
    """A scene model's judged segmentations, best first (``ranked``: the ones it starts from), before any
    becomes a start: ``prob`` is where its objects were sought (over a background, what moves) and ``background``
    the static image [H, W] they start over (None: none)."""

    prob: Problem
    ranked: list[Segmentation]
    background: np.ndarray | None = None

    def start(self, i: int) -> Start:
        """Start ``i``: segmentation ``i`` as SDF frames (Algorithm 2), where its objects were seen, the background."""
        seg = self.ranked[i]
        return Start(masks_to_sdf(seg.masks, self.prob.grid.pixel_size, workers=torch.get_num_threads()),
                     seg.intensities, seg, sightings(self.prob, seg.masks), self.background)


@dataclass(frozen=True)
class Sought:
    """Where a scene model's objects are sought: the ``prob`` (over a background, what moves), the static image
    [H, W] they start over (None: none) and the sinogram ``judge`` of its segmentations (judge.py; None with
    ``init.levels=fbp``), which models of other K share."""

    prob: Problem
    background: np.ndarray | None
    judge: Judge | None


def sought(prob: Problem, n_objects: int, init: InitConf, background: BackgroundConf | None = None) -> Sought:
    """Where ``n_objects`` objects are sought in ``prob``: with ``background=image`` in what moves, over a static
    background's start (background.py; one object there on its focused path), else in ``prob`` itself."""
    static = None
    if background is not None and background.name == "image":
        static = static_start(prob.fbp, background.moving_share)
        if not static.moving.any():
            log.warning("background=image: nothing moves in these data (the FBP frames do not change over the "
                        "scan): the background holds the whole image and the objects start empty")
        moved = moving_problem(prob, static)
        if n_objects == 1 and static.moving.any():
            moved = lone_mover(prob, moved, static.moving)
        prob = moved
    return Sought(prob, None if static is None else static.image, judge_of(prob, init))


def search(where: Sought, n_objects: int, init: InitConf, rng: np.random.Generator) -> Found:
    """The judged segmentations a run starts from, best first: the judge's ``init.starts`` best with K >= 2,
    the best one with K = 1 (``init.levels=sinogram``: judged by how well the masks explain the fitted views,
    which also gives a(k))."""
    ranked = segmentations(where.prob.fbp, n_objects, rng, init.kappa, init.gmm_share, init.route, where.judge)
    return Found(where.prob, ranked[:init.starts] if n_objects > 1 else ranked[:1], where.background)


def find_starts(prob: Problem, n_objects: int, init: InitConf, rng: np.random.Generator,
                background: BackgroundConf | None = None) -> list[Start]:
    """Every start ``search`` finds where ``sought`` seeks them (each as SDF frames), best judged first."""
    found = search(sought(prob, n_objects, init, background), n_objects, init, rng)
    return [found.start(i) for i in range(len(found.ranked))]


def judge_of(prob: Problem, init: InitConf) -> Judge | None:
    """The sinogram judge of segmentations of ``prob``'s FBP frames by its fitted views (judge.py; None with
    ``init.levels=fbp``)."""
    if init.levels != "sinogram":
        return None
    fitted, views = torch.from_numpy(prob.fit_views), prob.views
    return sinogram_judge(prob.init_times, views.values[fitted], views.angles[fitted], views.times[fitted],
                          views.geometry, prob.grid.extent)


def sightings(prob: Problem, masks: np.ndarray) -> Sightings:
    """Where the objects of ``masks`` [F, K, H, W] were seen at ``prob.init_times``: each mask's centroid
    and principal axis; a lone object's centre is its mass centroid read off the views' first
    moments (``prob.centres``; trajectory.py, exact in parallel beam, where each FBP frame's
    half-rotation window lags fast motion, 10-24 px along the rays at 200 deg/rotation; over a
    background, that path scaled into focus: background.py), held by the fit; an elongated rigid one's
    angle is its axis read off their second moments (``prob.orientations``; orientation.py), turned with it."""
    seen = mask_sightings(masks, prob.init_times)
    if prob.centres is None or masks.shape[1] > 1:
        return seen
    seen = replace(seen, centres=torch.from_numpy(prob.centres[:, None, :]).float(), held=True)
    if prob.orientations is None:
        return seen
    return replace(seen, angles=torch.from_numpy(prob.orientations[:, None]).float(), turned=0)


def turned_start(prob: Problem, start: Start, k: int) -> Start:
    """``start`` with object ``k`` turning with the part's axis read off the views (``prob.part_orientations``;
    orientation.turning_part) about its masks' mean centre: where a free field turning it starts."""
    angles = start.seen.angles.clone()
    angles[:, k] = torch.from_numpy(prob.part_orientations).float()
    return replace(start, seen=replace(start.seen, angles=angles, turned=k))
