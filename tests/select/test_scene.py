"""Which scene models a run races, from how well each one's judged masks explain the views."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pytest

from nct.select.candidates import SceneModel
from nct.select.scene import interior, raced


@dataclass
class Judged:
    """A scene model and its best judged residual: all that ``raced`` reads of a set-up."""

    model: SceneModel
    judged: float


def labels(setups: list[Judged]) -> list[str]:
    return [s.model.label for s in raced(setups)]


@pytest.mark.parametrize("two, expected", [(0.11, ["k1_none"]), (0.09, ["k1_none", "k2_none"]),
                                           (0.07, ["k1_none", "k2_none"]), (0.05, ["k2_none"])])
def test_an_object_must_earn_its_place(two, expected):
    """An object is priced at a factor 1 / 0.8 of the residual: two objects that do not cut 0.1 leave one alone;
    within a factor 1.25 of the break-even 0.08 both are raced (the held-out views choose); 0.05 proposes two."""
    assert labels([Judged(SceneModel(1), 0.1), Judged(SceneModel(2), two)]) == expected


def test_each_background_races_its_own_cheapest():
    """The judge sets K over each background; the held-out views alone choose the background, so the cheapest
    over each is raced however the two compare (with its runner-up within 1.25)."""
    plain = Judged(SceneModel(1), 0.1)
    assert labels([plain, Judged(SceneModel(1, "image"), 0.5)]) == ["k1_none", "k1_image"]
    image = [Judged(SceneModel(1, "image"), 0.02), Judged(SceneModel(2, "image"), 0.0155)]
    assert labels([plain, Judged(SceneModel(2), 0.2), *image]) == ["k1_none", "k1_image", "k2_image"]
    assert labels([plain, Judged(SceneModel(1, "image"), 0.02), Judged(SceneModel(2, "image"), 0.01)]) == \
        ["k1_none", "k2_image"]


def test_a_rim_has_no_inside():
    """A disc has an inside; its one-pixel partial-volume ring, which a finer segmentation of noise-free views
    finds as a second object, has none."""
    yy, xx = np.mgrid[:32, :32]
    r = np.hypot(yy - 15.5, xx - 15.5)
    disc, ring = r < 8, (r >= 8) & (r < 9)
    assert interior(np.stack([disc, disc])[None]) > 0.7
    assert interior(np.stack([disc | ring, ring])[None]) == 0.0
