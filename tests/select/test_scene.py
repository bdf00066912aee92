"""Which scene models a run races, from how well each one's judged masks explain the views."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from nct.init.judge import FLOOR, MIN_SHARE
from nct.init.segmentation import Segmentation
from nct.select.candidates import SceneModel
from nct.select.scene import (
    SceneChoice,
    image_earned,
    interior,
    model_price,
    offered,
    raced,
    up_to_dearer,
    waiting,
)


def labels(judged: dict[SceneModel, float], left: float = 0.3) -> list[str]:
    """The labels of the models ``raced`` among those with these judged residuals, an image's start alone leaving
    ``left`` of the views."""
    return [m.label for m in raced({m: model_price(r, m) for m, r in judged.items()}, left)]


@pytest.mark.parametrize("two, expected", [(0.11, ["k1_none"]), (0.09, ["k1_none", "k2_none"]),
                                           (0.07, ["k1_none", "k2_none"]), (0.05, ["k2_none"])])
def test_an_object_must_earn_its_place(two, expected):
    """An object is priced at a factor 1 / 0.8 of the residual: two objects that do not cut 0.1 leave one alone;
    within a factor 1.25 of the break-even 0.08 both are raced (the held-out views choose); 0.05 proposes two."""
    assert labels({SceneModel(1): 0.1, SceneModel(2): two}) == expected


def test_each_background_races_its_own_cheapest():
    """The judge sets K over each background; the held-out views alone choose the background, so the cheapest
    over each is raced however the two compare (with its runner-up within 1.25)."""
    plain = {SceneModel(1): 0.1}
    assert labels(plain | {SceneModel(1, "image"): 0.5}) == ["k1_none", "k1_image"]
    image = {SceneModel(1, "image"): 0.02, SceneModel(2, "image"): 0.0155}
    assert labels(plain | {SceneModel(2): 0.2} | image) == ["k1_none", "k1_image", "k2_image"]
    assert labels(plain | {SceneModel(1, "image"): 0.02, SceneModel(2, "image"): 0.01}) == ["k1_none", "k2_image"]


def test_an_image_must_earn_its_place():
    """An image is raced where its start alone cuts the views to 0.8 of them, or where the cheapest model over it
    is priced at 0.8 of the cheapest plain one or less (a still object K missed); else it only soaks up misfit."""
    plain, image = {SceneModel(1): 0.02}, {SceneModel(1, "image"): 0.02}
    assert labels(plain | image, left=0.8) == ["k1_none", "k1_image"]
    assert labels(plain | image, left=0.81) == ["k1_none"]
    assert labels(plain | {SceneModel(1, "image"): 0.016}, left=0.99) == ["k1_none", "k1_image"]
    assert labels(plain | {SceneModel(1, "image"): 0.017}, left=0.99) == ["k1_none"]
    assert image_earned(0.99, {m: model_price(0.02, m) for m in image})  # a user's background=image: none plain
    assert not image_earned(0.1, {m: model_price(0.02, m) for m in plain})  # no model over an image priced


def test_the_reserve_is_the_cheapest_model_not_raced_then_one_more_object():
    """What a run races where its winner is worse than FBP (select/race.py): the priced models not raced, cheapest
    first (an image only where it earned its place), then one more object than the winner, up to MAX_OBJECTS."""
    prices = {m: model_price(r, m) for m, r in {SceneModel(1): 0.1, SceneModel(2): 0.11, SceneModel(3): 0.095,
                                                 SceneModel(1, "image"): 0.09}.items()}
    first = raced(prices, 0.99)
    assert [m.label for m in first] == ["k1_none"]
    assert waiting(prices, 0.99, first) == [SceneModel(2), SceneModel(3)]  # the image did not earn its place
    assert waiting(prices, 0.5, raced(prices, 0.5)) == [SceneModel(2), SceneModel(3)]  # the image raced at first
    setups = {m: SimpleNamespace(model=m) for m in (SceneModel(2), SceneModel(3), SceneModel(4, "image"))}
    choice = SceneChoice([], [setups[SceneModel(3)]], setups.get)
    assert choice.reserve({SceneModel(1)}, SceneModel(1)).model == SceneModel(3)
    assert choice.reserve({SceneModel(1), SceneModel(3)}, SceneModel(1)).model == SceneModel(2)
    assert choice.reserve({SceneModel(2), SceneModel(3)}, SceneModel(3)) is None  # no k4_none offered
    assert choice.reserve({SceneModel(3)}, SceneModel(4, "image")) is None  # MAX_OBJECTS objects
    assert SceneChoice([], []).reserve(set(), SceneModel(1)) is None  # K set by the user: none on demand


def test_objects_are_priced_up_to_the_first_dearer_model():
    """Fewest objects first: pricing stops after the first model dearer than the cheapest before it, or at one
    not offered (None); those priced are kept."""
    asked = []

    def priced(k):
        asked.append(k)
        return {1: 3.0, 2: 2.0, 3: 2.5, 4: 1.0}[k]

    assert up_to_dearer([1, 2, 3, 4], priced) == {1: 3.0, 2: 2.0, 3: 2.5} and asked == [1, 2, 3]
    assert up_to_dearer([1, 2, 3], lambda k: None if k == 2 else 1.0) == {1: 1.0}


def test_a_rim_has_no_inside():
    """A disc has an inside; its one-pixel partial-volume ring, which a finer segmentation of noise-free views
    finds as a second object, has none."""
    yy, xx = np.mgrid[:32, :32]
    r = np.hypot(yy - 15.5, xx - 15.5)
    disc, ring = r < 8, (r >= 8) & (r < 9)
    assert interior(np.stack([disc, disc])[None]) > 0.7
    assert interior(np.stack([disc | ring, ring])[None]) == 0.0


def test_objects_that_explain_nothing_are_not_offered():
    """A model is priced only where its best segmentation's objects are drawn and together explain some of the
    views: objects over an image of a still scene, which least squares gives 0 (the judge's floor), are not
    (scene058: one such object over an image drew two still ellipses at 0.987 Dice against FBP's 0.998)."""
    yy, xx = np.mgrid[:32, :32]
    disc = (np.hypot(yy - 15.5, xx - 15.5) < 8)[None, None]
    assert offered(Segmentation(disc, np.array([0.4])), chosen=True)
    assert not offered(Segmentation(disc, np.array([MIN_SHARE * FLOOR])), chosen=True)
    assert not offered(Segmentation(np.zeros_like(disc), np.array([0.4])), chosen=True)
    two = np.concatenate([disc, np.roll(disc, 10, axis=-1)], axis=1)
    assert offered(Segmentation(two, np.array([0.4, MIN_SHARE * 0.4])), chosen=True)  # one at the least share
