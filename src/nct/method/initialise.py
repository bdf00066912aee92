"""Where fits start (Algorithms 1-2): segmentations of the FBP frames, each as SDF frames InitFit fits.

With several objects, a segmentation can hand an object to the background or split one in two, and
a fit cannot create an object no field starts on: the judge's ``init.starts`` best segmentations
are all offered to the tournament (select.py). One object starts on the brightest structure whichever
segmentation wins, and the fit moves its boundary, so one start is enough there.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch

from nct.method.conf import InitConf
from nct.method.judge import sinogram_judge
from nct.method.motion import Sightings, mask_sightings
from nct.method.prepare import Problem
from nct.method.sdf import masks_to_sdf
from nct.method.segment import Segmentation, segmentations


@dataclass(frozen=True)
class Start:
    """Where a fit may start: InitFit's SDF ``targets`` [F, K, H, W] (method units), a(k)
    ``intensities`` [K] (None: the field's own), the ``segmentation`` they came from (None: a
    refinement's own frames) and where its objects were ``seen`` (a moved template's first poses;
    None: the field's own)."""

    targets: np.ndarray
    intensities: np.ndarray | None = None
    segmentation: Segmentation | None = None
    seen: Sightings | None = None


def find_starts(prob: Problem, n_objects: int, init: InitConf, rng: np.random.Generator) -> list[Start]:
    """The starts of a run, best judged first: the judge's ``init.starts`` best segmentations with
    K >= 2, the best one with K = 1 (``init.levels=sinogram``: judged by how well the masks explain
    the fitted views, which also gives a(k))."""
    judge = None
    if init.levels == "sinogram":
        fitted = torch.from_numpy(prob.fit_views)
        views = prob.views
        judge = sinogram_judge(prob.init_times, views.values[fitted], views.angles[fitted], views.times[fitted],
                               views.geometry, prob.grid.extent)
    ranked = segmentations(prob.fbp, n_objects, rng, init.kappa, init.gmm_share, init.route, judge)
    chosen = ranked[:init.starts] if n_objects > 1 else ranked[:1]
    return [Start(masks_to_sdf(s.masks, prob.grid.pixel_size, workers=torch.get_num_threads()), s.intensities, s,
                  mask_sightings(s.masks, prob.init_times)) for s in chosen]
