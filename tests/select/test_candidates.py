"""The tournament's typed candidates: what a scene model offers, and names made from fields."""

from __future__ import annotations

import pytest

from nct.select.candidates import Candidate, SceneModel, candidates
from nct.select.conf import SelectionConf


@pytest.mark.parametrize("rungs, turning, extra", [(["free"], 3, ["free_turn0", "free_turn1", "free_turn2"]),
                                                   (["free"], 0, []), (["static", "rigid"], 2, [])])
def test_a_held_part_axis_adds_one_turned_free_field_per_object(rungs, turning, extra):
    """Which of K objects turns with a part's axis (fit/problem.py) is raced as the free rung from the best
    judged start turning each of them, the same model as the unturned free field; no free rung, none."""
    pool = candidates(SelectionConf(rungs=rungs), 2, span=1.0, scene=SceneModel(3), turning=turning)
    assert [c.name for c in pool] == [f"{r}{s}" for r in rungs for s in ("", "_start1")] + extra
    turned = [c for c in pool if c.turning is not None]
    assert [c.turning for c in turned] == list(range(len(extra)))
    assert all(c.start == 0 and c.simplicity == pool[0].simplicity for c in turned)


def test_names_and_streams_come_from_the_fields():
    """A candidate's key (its random streams) names its rung, band, start, turn and restart; the scene's label
    prefixes its name only where the run compares scene models, so a model's fits match a run of it alone."""
    scene = SceneModel(2, "image")
    band = Candidate(scene, "free", start=1, f_max=0.5, restart=True)
    assert band.key == "free_band_start1_restart" and band.name == band.key
    named = Candidate(scene, "rigid", scene_named=True)
    assert named.key == "rigid" and named.name == "k2_image_rigid"
    assert Candidate(scene, "free").continues_run and not band.continues_run
    assert Candidate(scene, "free", turning=1).key == "free_turn1"
    assert Candidate(scene, "static").simplicity < Candidate(scene, "free").simplicity < band.simplicity
