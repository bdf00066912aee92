"""select/stillness.py: a ladder of static and moving rungs fits static alone where the views' conjugates say
nothing moves and the moving rungs alone where they say something does, and lists the rungs it left out; where they
cannot tell, or the rule is off, the ladder stays whole."""

from __future__ import annotations

import math
from dataclasses import replace

import pytest

from nct.select.candidates import Candidate, SceneModel
from nct.select.conf import SelectionConf
from nct.select.stillness import ladder
from tests.conftest import circle

AUTO = SelectionConf(rungs=["static", "rigid", "affine", "free"])


def test_a_still_scan_fits_the_static_rung_alone_and_says_why():
    sino, _, _ = circle(0.0, views=180, size=48)
    rungs = ladder(sino, AUTO)
    assert rungs.motion.rungs == ["static"] and rungs.left_out == ["rigid", "affine", "free"]
    rows = rungs.rows(Candidate(SceneModel(2), "static", start=1))
    assert [r.rung for r in rows] == [r.candidate for r in rows] == ["rigid", "affine", "free"]
    named = rungs.rows(Candidate(SceneModel(3, "none"), "static", scene_named=True))
    assert [r.candidate for r in named] == ["k3_none_rigid", "k3_none_affine", "k3_none_free"]
    assert all(r.steps == 0 and math.isnan(r.heldout_misfit) and r.n_objects == 2 for r in rows)
    assert all("not fitted: the views' conjugate pairs agree" in r.verdict for r in rows)
    assert replace(rungs.motion, rungs=AUTO.rungs) == AUTO  # only the rungs change


@pytest.mark.parametrize("motion, kept", [(AUTO, ["rigid", "affine", "free"]),
                                          (SelectionConf(rungs=["static", "free"]), ["free"])])
def test_a_moving_scan_leaves_the_static_rung_out_and_says_why(motion, kept):
    sino, _, _ = circle(100.0, views=180, size=48)
    rungs = ladder(sino, motion)
    assert rungs.motion.rungs == kept and rungs.left_out == ["static"]
    (row,) = rungs.rows(Candidate(SceneModel(1), kept[0]))
    assert row.rung == "static" and row.steps == 0 and "differ beyond their noise" in row.verdict
    assert "something moves" in row.verdict


@pytest.mark.parametrize("deg, motion", [(100.0, replace(AUTO, still_ratio=0.0)), (0.0, replace(AUTO, still_ratio=0.0)),
                                         (0.0, SelectionConf(rungs=["rigid", "free"])),
                                         (0.0, SelectionConf(rungs=["free"]))])
def test_the_ladder_stays_whole_where_the_rule_is_off_or_it_holds_no_choice(deg, motion):
    """The rule turned off (a moving and a still disc), a ladder without the static rung, one rung: nothing is left
    out."""
    sino, _, _ = circle(deg, views=180, size=48)
    rungs = ladder(sino, motion)
    assert rungs.motion == motion and rungs.left_out == [] and rungs.rows(Candidate(SceneModel(1), "free")) == []


def test_under_half_a_turn_the_ladder_stays_whole():
    sino, _, _ = circle(0.0, views=180, size=48)
    short = replace(sino, values=sino.values[:80], angles=sino.angles[:80], times=sino.times[:80])
    assert ladder(short, AUTO).motion == AUTO
