"""One scene model's share of a run: the data prepared for it and the starts found for it."""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from nct.acquisition.scanner import ImageGrid
from nct.acquisition.sinogram import Sinogram
from nct.fit.conf import HeldoutConf, LossConf
from nct.fit.problem import Problem, prepare
from nct.fit.session import Start
from nct.init.conf import BackgroundConf, InitConf
from nct.init.starts import find_starts
from nct.select.candidates import SceneModel


@dataclass
class SceneSetup:
    """One scene model's share of a run: its ``Problem`` (fit/problem.py), its judged ``starts`` and the run's
    random generator as a run of that model alone holds it once they are found (the paper's field continues it)."""

    model: SceneModel
    prob: Problem
    starts: list[Start]
    rng: np.random.Generator


def set_up(sino: Sinogram, grid: ImageGrid, scene: SceneModel, seed: int, loss: LossConf, init: InitConf,
           heldout: HeldoutConf, background: BackgroundConf, fbp: tuple[str, float]) -> SceneSetup:
    """Prepare the data (fit/problem.py) and find the starts (init/starts.py) of one ``scene`` model; ``fbp``: the
    FBP frames' filter and window (degrees). A lone object without a background is held along its path, several
    without one are searched for a turning part; over a background the objects are sought in what moves."""
    image = scene.background == "image"
    prob = prepare(sino, grid, loss, init, heldout, *fbp, lone=scene.n_objects == 1 and not image,
                   parts=scene.n_objects > 1 and not image)
    rng = np.random.default_rng(seed)
    starts = find_starts(prob, scene.n_objects, init, rng, replace(background, name=scene.background))
    return SceneSetup(scene, prob, starts, rng)
