"""The scene models a run compares (objects, background), and each one's share of the run: the data prepared
for it and the starts found for it."""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from nct.acquisition.scanner import ImageGrid
from nct.acquisition.sinogram import Sinogram
from nct.errors import InputError, NoObjectError
from nct.fit.conf import HeldoutConf, LossConf
from nct.fit.problem import Problem, prepare
from nct.fit.session import Start
from nct.init.conf import BackgroundConf, InitConf
from nct.init.starts import Found, Sought, search, sought
from nct.select.candidates import BACKGROUND_ORDER, SceneModel

MAX_OBJECTS = 4  # the most objects of distinct intensity a run proposes from the data (data.n_objects=auto)
JUDGED_TOLERANCE = 0.1  # the fewest objects whose masks explain the views within this of the best K's


@dataclass
class SceneSetup:
    """One scene model's share of a run: its ``Problem`` (fit/problem.py), its judged segmentations (``found``:
    where its fits may start, each made a start when a candidate first needs it) and the run's random generator
    as a run of that model alone holds it once they are found (the paper's field continues it)."""

    model: SceneModel
    prob: Problem
    found: Found
    rng: np.random.Generator
    made: dict[int, Start] = field(default_factory=dict)

    @property
    def n_starts(self) -> int:
        return len(self.found.ranked)

    @property
    def judged(self) -> float:
        """How well the best judged segmentation's masks explain the fitted views (judge.py: relative residual)."""
        return self.found.ranked[0].misfit

    def start(self, i: int) -> Start:
        """Start ``i`` (init/starts.Found.start), made once."""
        if i not in self.made:
            self.made[i] = self.found.start(i)
        return self.made[i]


class Preparation:
    """The run's data prepared for its scene models (fit/problem.py), once per way of preparing (a lone object
    without a background held along its path, several searched for a turning part, over a background plain),
    and where each way seeks its objects (init/starts.Sought: the judge shared by models of every K)."""

    def __init__(self, sino: Sinogram, grid: ImageGrid, loss: LossConf, init: InitConf, heldout: HeldoutConf,
                 background: BackgroundConf, fbp: tuple[str, float]) -> None:
        self.args, self.init, self.background = (sino, grid, loss, init, heldout, *fbp), init, background
        self.problems: dict[tuple[bool, bool], Problem] = {}
        self.places: dict[tuple[bool, bool, str, bool], Sought] = {}

    @staticmethod
    def way(scene: SceneModel) -> tuple[bool, bool]:
        """How ``scene``'s data are prepared: (a lone object held along its path, parts searched for a turning one)."""
        image = scene.background == "image"
        return scene.n_objects == 1 and not image, scene.n_objects > 1 and not image

    def of(self, scene: SceneModel) -> Problem:
        """The data prepared for ``scene``."""
        way = self.way(scene)
        if way not in self.problems:
            self.problems[way] = prepare(*self.args, lone=way[0], parts=way[1])
        return self.problems[way]

    def where(self, scene: SceneModel) -> Sought:
        """Where ``scene``'s objects are sought (one object over a background: on its own focused path)."""
        key = (*self.way(scene), scene.background, scene.n_objects == 1)
        if key not in self.places:
            background = replace(self.background, name=scene.background)
            self.places[key] = sought(self.of(scene), scene.n_objects, self.init, background)
        return self.places[key]


def set_up(prepared: Preparation, scene: SceneModel, seed: int) -> SceneSetup:
    """The data (fit/problem.py) and the judged segmentations (init/starts.py) of one ``scene`` model, from the run's
    ``seed`` as a run of that model alone draws them."""
    rng = np.random.default_rng(seed)
    return SceneSetup(scene, prepared.of(scene), search(prepared.where(scene), scene.n_objects, prepared.init, rng), rng)


def scene_setups(prepared: Preparation, n_objects: int | None, seed: int) -> list[SceneSetup]:
    """The scene models the run's tournament compares, set up: the user's K and background where set; otherwise,
    for each background offered (``background=auto``: none, then a static image), the fewest objects whose judged
    masks explain the views within ``JUDGED_TOLERANCE`` of the best of 1 ... ``MAX_OBJECTS`` (``fewest``)."""
    name = prepared.background.name
    backgrounds = BACKGROUND_ORDER if name == "auto" else (name,)
    if n_objects is not None:
        return [set_up(prepared, SceneModel(n_objects, b), seed) for b in backgrounds]
    if prepared.init.levels != "sinogram":
        raise InputError("data.n_objects=auto needs init.levels=sinogram (the judge that counts the objects): "
                         "set data.n_objects, or init.levels=sinogram")
    chosen = []
    for b in backgrounds:
        tried = [set_up(prepared, SceneModel(1, b), seed)]
        for k in range(2, MAX_OBJECTS + 1):
            try:
                tried.append(set_up(prepared, SceneModel(k, b), seed))
            except NoObjectError:
                break
        chosen.append(fewest(tried))
    return chosen


def fewest(tried: list[SceneSetup]) -> SceneSetup:
    """The set-up with the fewest objects whose judged misfit is within ``JUDGED_TOLERANCE`` of the best's."""
    best = min(s.judged for s in tried)
    return next(s for s in tried if s.judged <= (1 + JUDGED_TOLERANCE) * best)
