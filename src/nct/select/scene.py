"""The scene models a run compares (objects, background), and each one's share of the run: the data prepared
for it and the starts found for it."""

from __future__ import annotations

import logging
import math
from collections.abc import Callable, Collection, Sequence
from dataclasses import dataclass, field, replace
from typing import TypeVar

import numpy as np
import torch
from scipy import ndimage

from nct.acquisition.scanner import ImageGrid
from nct.acquisition.sinogram import Sinogram
from nct.errors import InputError, NoObjectError
from nct.fit.conf import HeldoutConf, LossConf
from nct.fit.problem import Problem, prepare
from nct.fit.session import Start
from nct.init.conf import BackgroundConf, InitConf
from nct.init.judge import explains_nothing, views_norm
from nct.init.segmentation import Segmentation
from nct.init.starts import Found, Sought, search, sought
from nct.select.candidates import BACKGROUND_ORDER, SceneModel

log = logging.getLogger(__name__)
MAX_OBJECTS = 4  # the most objects of distinct intensity a run proposes from the data (data.n_objects=auto)
OBJECT_GAIN = 0.8  # the judge's price of an object: a model with one more must cut the residual to this share
RACE_MARGIN = 1.25  # the runner-up is raced too where its price is within this factor of the proposal's
# An object with fewer of its pixels inside it (its four neighbours in its mask too) is a partial-volume rim or a
# streak, not an object: a model of several that needs one is not offered (the scene-model diagnostic's 101 files:
# the runner-up raced on 42 instead of 72, the truth's model among those raced on 77 instead of 79).
MIN_INTERIOR = 0.1

T = TypeVar("T")


@dataclass
class SceneSetup:
    """One scene model's share of a run: its ``Problem`` (fit/problem.py), its judged segmentations (``found``:
    where its fits may start, each made a start when a candidate first needs it) and the run's random generator
    as a run of that model alone holds it once they are found (the paper's field continues it)."""

    model: SceneModel
    prob: Problem
    found: Found
    rng: np.random.Generator
    scale: float = 1.0  # the judged residual times this is relative to the whole views (over a background: < 1)
    made: dict[int, Start] = field(default_factory=dict)

    @property
    def n_starts(self) -> int:
        return len(self.found.ranked)

    @property
    def judged(self) -> float:
        """How well the best judged segmentation's masks explain the fitted views (judge.py's relative residual),
        relative to the whole views for every model alike (over a background the judge compares what the image
        leaves)."""
        return self.found.ranked[0].misfit * self.scale

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

    def still_left(self) -> float:
        """What the background's start alone (init/background.py: the FBP frames' still part) leaves of the fitted
        views, relative to theirs: 1 where nothing is still, near 0 where nothing moves."""
        plain = SceneModel(2, "image")  # K >= 2 seek their objects in what moves, over the plain start
        return _share(self.where(plain).prob, self.of(plain), 1)

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
    prob, where = prepared.of(scene), prepared.where(scene)
    found = search(where, scene.n_objects, prepared.init, rng)
    scale = 1.0 if where.prob is prob else _share(where.prob, prob, scene.n_objects)
    return SceneSetup(scene, prob, found, rng, scale)


def _share(part: Problem, whole: Problem, n_objects: int) -> float:
    """The norm of ``part``'s fitted views (what the judge compares K masks with there) over ``whole``'s."""
    n_pixels, fitted = n_objects * whole.grid.size**2, torch.from_numpy(whole.fit_views)
    whole_norm = views_norm(whole.views.values[fitted], n_pixels)
    return views_norm(part.views.values[fitted], n_pixels) / max(whole_norm, 1e-30)


@dataclass
class SceneChoice:
    """The scene models a run races (``setups``, simplest first), and those it may race next where the winner
    explains the held-out views worse than FBP (select/race.py): the priced models not raced, cheapest first
    (``waiting``), then one more object than the winner (``more``: set up on demand; None where not offered)."""

    setups: list[SceneSetup]
    waiting: list[SceneSetup] = field(default_factory=list)
    more: Callable[[SceneModel], SceneSetup | None] = lambda model: None

    def reserve(self, raced: Collection[SceneModel], winner: SceneModel) -> SceneSetup | None:
        """The next scene model to race after ``raced``: the cheapest waiting; where none is left, one more object
        than the ``winner`` over its background, up to ``MAX_OBJECTS`` (the judge's price stopped short of it)."""
        left = [s for s in self.waiting if s.model not in raced]
        if left:
            return left[0]
        bigger = SceneModel(winner.n_objects + 1, winner.background)
        return None if bigger in raced or bigger.n_objects > MAX_OBJECTS else self.more(bigger)


def scene_setups(prepared: Preparation, n_objects: int | None, seed: int) -> SceneChoice:
    """The scene models the run's tournament compares, set up, simplest first: those the user's K and
    background allow (``data.n_objects`` auto: 1 ... ``MAX_OBJECTS``; ``background=auto``: none and an image),
    each priced by how well its judged masks explain the views (``price``; over each background fewest objects
    first, up to the first dearer than one before: ``up_to_dearer``), those with an object not found or (where K
    is chosen) a rim among several left out (``offered``); for each background the cheapest, and the runner-up
    where its price is within ``RACE_MARGIN`` of it (``raced``: the held-out views then choose); the others
    ``waiting`` in reserve, and where K is chosen, more objects on demand (`SceneChoice.reserve`)."""
    name = prepared.background.name
    backgrounds = BACKGROUND_ORDER if name == "auto" else (name,)
    counts = range(1, MAX_OBJECTS + 1) if n_objects is None else (n_objects,)
    if len(backgrounds) * len(counts) == 1:
        return SceneChoice([set_up(prepared, SceneModel(counts[0], backgrounds[0]), seed)])
    if prepared.init.levels != "sinogram":
        raise InputError("choosing the objects or the background from the data needs init.levels=sinogram (the "
                         "judge that prices them): set data.n_objects and background, or init.levels=sinogram")
    return _priced(prepared, backgrounds, counts, n_objects is None, seed)


def _priced(prepared: Preparation, backgrounds: tuple[str, ...], counts: Sequence[int], chosen: bool,
            seed: int) -> SceneChoice:
    """The models over each of ``backgrounds`` with ``counts`` objects, set up and priced in turn as `up_to_dearer`
    asks (those not ``offered`` unpriced), then ``raced``, the rest `waiting`; with none priced, the first one
    found, or the first `NoObjectError`."""
    setups, errors = {}, []

    def offer(model: SceneModel) -> SceneSetup | None:
        if model not in setups:
            try:
                setups[model] = set_up(prepared, model, seed)
            except NoObjectError as err:
                errors.append(err)
                return None
        return setups[model] if offered(setups[model].found.ranked[0], chosen) else None

    def priced(model: SceneModel) -> float | None:
        setup = offer(model)
        return None if setup is None else price(setup)

    prices = {m: p for b in backgrounds for m, p in up_to_dearer([SceneModel(k, b) for k in counts], priced).items()}
    if not prices:
        if not setups:
            raise errors[0]
        return SceneChoice([next(iter(setups.values()))])
    image = {p for m, p in prices.items() if m.background == "image"}
    left = prepared.still_left() if image else 1.0
    if image and not image_earned(left, prices):
        log.info("no model over an image raced: its start alone leaves %.2f of the views, and the cheapest over it "
                 "prices %.2fx the cheapest plain one; an image must cut either to %.2f (select/scene.image_earned)",
                 left, math.exp(min(image) - min(p for m, p in prices.items() if m.background == "none")), OBJECT_GAIN)
    first = raced(prices, left)
    more = {"more": offer} if chosen else {}  # more objects only where K is the data's to choose
    return SceneChoice([setups[m] for m in first], [setups[m] for m in waiting(prices, left, first)], **more)


def up_to_dearer(models: list[T], priced: Callable[[T], float | None]) -> dict[T, float]:
    """``models`` (one background's, fewest objects first) priced in turn up to the first dearer than the cheapest
    before it, or not priced (None: no such model there): more objects seldom pay where one more did not (the
    scene-model table: the same truth raced on 84 of 101 files as with every K priced, 5.1 models judged per file
    instead of 6.7)."""
    prices: dict[T, float] = {}
    for model in models:
        p = priced(model)
        if p is None:
            break
        prices[model] = p
        if p > min(prices.values()):
            break
    return prices


def offered(best: Segmentation, chosen: bool) -> bool:
    """Whether a model whose best judged segmentation is ``best`` is priced: every object found, and together
    explaining some of the views (over a background where nothing moves the objects start empty, or are noise the
    judge gives no intensity: `judge.explains_nothing`), and where K is ``chosen`` from the data, none of several a
    rim (``MIN_INTERIOR``)."""
    masks = best.masks
    if not masks.any(axis=(0, 2, 3)).all() or explains_nothing(best.intensities):
        return False
    return not chosen or masks.shape[1] == 1 or interior(masks) >= MIN_INTERIOR


def raced(prices: dict[SceneModel, float], left: float, gain: float = OBJECT_GAIN,
          margin: float = RACE_MARGIN) -> list[SceneModel]:
    """``cheapest_each`` background's of the priced models, simplest first; those over an image only where
    `image_earned` (``left``: what the image's start alone leaves of the views)."""
    earned = image_earned(left, prices, gain)
    kept = {m: p for m, p in prices.items() if m.background != "image" or earned}
    return sorted(cheapest_each(list(kept), lambda m: m.background, kept.__getitem__, margin),
                  key=lambda m: m.simplicity)


def waiting(prices: dict[SceneModel, float], left: float, first: list[SceneModel],
            gain: float = OBJECT_GAIN) -> list[SceneModel]:
    """The priced models not raced ``first`` (those over an image only where `image_earned`), cheapest first: what
    the judge put next, raced where the winner explains the held-out views worse than FBP does (select/race.py).
    The judge cannot see a part its segmentation misses: scene021 of the generalisation benchmark (a turning
    ellipse and a still one) priced one object cheapest, whose fit left 0.100 of the held-out views (FBP 0.047);
    two, raced, 0.0096 (Dice 0.960 -> 0.998)."""
    earned = image_earned(left, prices, gain)
    rest = [m for m in prices if m not in first and (m.background != "image" or earned)]
    return sorted(rest, key=prices.__getitem__)


def image_earned(left: float, prices: dict[SceneModel, float], gain: float = OBJECT_GAIN) -> bool:
    """Whether the models over an image priced (``prices``) are raced: an image, like an object, must cut a
    residual to ``gain`` of it: the whole views' by its start alone (``left`` of them remains; files with an
    image in the scene-model table leave 0.085-0.31), or the plain models' by the models over it (the cheapest's
    price lower by log(1 / gain); a static object beside a mover that K missed). Where neither holds the image
    only soaks up misfit: the default circle raced one to its end (0.96x the plain model's held-out misfit), the
    letters chose one at 0.013 Dice below the plain model."""
    plain = [p for m, p in prices.items() if m.background == "none"]
    image = [p for m, p in prices.items() if m.background == "image"]
    return bool(image) and (left <= gain or not plain or min(image) <= min(plain) + math.log(gain))


def cheapest_each(items: list[T], background: Callable[[T], str], priced: Callable[[T], float],
                  margin: float = RACE_MARGIN) -> list[T]:
    """For each background (``BACKGROUND_ORDER``), the `cheapest` of ``items`` over it. The judge sets K; which
    background is for the held-out views alone: K uniform objects explain a textured body's views about as well
    as an image under its moving parts (the scene-model table: with a price on the image, 2 of 9 textured files
    proposed one)."""
    return [i for b in BACKGROUND_ORDER for i in cheapest([i for i in items if background(i) == b], priced, margin)]


def cheapest(items: list[T], priced: Callable[[T], float], margin: float = RACE_MARGIN) -> list[T]:
    """The cheapest of ``items`` by ``priced``, and the runner-up where its price is within ``margin`` (a factor)
    of the cheapest's, cheapest first (ties in ``items``' order): `raced`'s choice, also scored offline."""
    ranked = sorted(items, key=priced)
    return [s for s in ranked[:2] if priced(s) <= priced(ranked[0]) + math.log(margin)] if ranked else []


def interior(masks: np.ndarray) -> float:
    """The least share, over the objects of ``masks`` [F, K, H, W] bool, of an object's pixels whose four
    neighbours are in its mask too (a body has an inside; a rim or streak 1-2 px wide next to none)."""
    cross = ndimage.generate_binary_structure(2, 1)[None, None]
    inner = ndimage.binary_erosion(masks, structure=cross, border_value=1)
    return float(min(inner[:, k].sum() / max(1, masks[:, k].sum()) for k in range(masks.shape[1])))


def price(setup: SceneSetup) -> float:
    """A scene model's price (`model_price` of its best judged segmentation's residual)."""
    return model_price(setup.judged, setup.model)


def model_price(judged: float, model: SceneModel, gain: float = OBJECT_GAIN) -> float:
    """The price of ``model`` whose best judged segmentation leaves the relative residual ``judged`` (judge.py): its
    log, plus ``log(1 / gain)`` an object (a model must earn its objects)."""
    return math.log(max(judged, 1e-12)) + model.n_objects * math.log(1 / gain)
