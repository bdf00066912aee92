"""The tournament: the rung schedule, stopping a fit that falls behind, parsimony, the table."""

from __future__ import annotations

import math
from dataclasses import replace

import pytest

from nct.select.candidates import Candidate, SceneModel
from nct.select.conf import SelectionConf
from nct.select.tournament import Tournament

CONF = SelectionConf(rungs=["static", "rigid", "free"], first_budget=0.25, tolerance=0.05, milestone_margin=0.0)
SCENE = SceneModel(1)
STATIC, RIGID, FREE = (Candidate(SCENE, r) for r in CONF.rungs)


def history(losses: list[float], every: int = 100) -> list[tuple[int, float]]:
    return [(every * (i + 1), loss) for i, loss in enumerate(losses)]


def test_the_schedule_doubles_from_the_first_budget_on_the_checks():
    assert Tournament(1000, 50, CONF).milestones == [250, 500]
    assert Tournament(1000, 100, CONF).milestones == [300, 500]
    assert Tournament(1000, 100, SelectionConf(first_budget=0.1)).milestones == [100, 200, 400, 800]
    assert Tournament(1000, 0, CONF).milestones == []


def test_the_first_candidate_is_never_stopped():
    t = Tournament(1000, 100, CONF)
    assert not t.stops(FREE)(history([9.0, 9.0, 9.0]))


def test_a_simpler_fit_stops_at_a_milestone_only_beyond_the_tolerance():
    t = Tournament(1000, 100, CONF)
    t.record(FREE, history([1.0] * 10), 1000, 1.0)
    stops = t.stops(STATIC)
    assert not stops(history([1.2]))  # step 100: before the first milestone (300)
    assert not stops(history([1.2, 1.2]))
    assert stops(history([1.2, 1.2, 1.2]))  # step 300, the first milestone: 20 % behind the freer model
    assert not stops(history([1.2, 1.2, 1.04]))  # within 5 % of it
    assert not stops(history([1.2, 1.2, 1.04, 1.5]))  # step 400 is no milestone
    entry = t.record(STATIC, history([1.2, 1.2, 1.2]), 300, math.nan)
    assert entry.pruned and "step 300" in entry.pruned


def test_a_freer_fit_must_lead_a_simpler_one_by_the_tolerance_to_go_on():
    t = Tournament(1000, 100, CONF)
    t.record(STATIC, history([1.0] * 10), 1000, 1.0)
    assert t.stops(FREE)(history([0.99, 0.99, 0.99]))  # ahead, but not by 5 %: parsimony keeps static
    assert not t.stops(FREE)(history([0.9, 0.9, 0.9]))


def test_another_start_of_the_same_model_must_lead_to_go_on():
    t = Tournament(1000, 100, CONF)
    t.record(FREE, history([1.0] * 10), 1000, 1.0)
    other = Candidate(SCENE, "free", start=1)
    assert t.stops(other)(history([1.01, 1.01, 1.01]))
    assert not t.stops(other)(history([0.99, 0.99, 0.99]))


def test_a_near_tie_at_a_milestone_goes_on():
    """Within ``milestone_margin`` of what it needs to win a fit goes on; beyond it, it stops, the margin named."""
    t = Tournament(1000, 100, replace(CONF, milestone_margin=0.05))
    t.record(FREE, history([1.0] * 10), 1000, 1.0)
    other = Candidate(SCENE, "free", start=1)
    assert not t.stops(other)(history([1.04, 1.04, 1.04]))
    assert t.stops(other)(history([1.06, 1.06, 1.06]))
    assert t.stops(STATIC)(history([1.12, 1.12, 1.12]))  # a simpler model: 1.05 x 1.05 allowed, 12 % behind
    assert not t.stops(STATIC)(history([1.1, 1.1, 1.1]))
    assert "6.0% above the 1 it needed" in t.record(other, history([1.06] * 3), 300, 1.06).pruned


def test_parsimony_keeps_the_simplest_within_tolerance():
    t = Tournament(1000, 100, CONF)
    t.record(STATIC, history([1.0] * 10), 1000, 1.00)
    t.record(RIGID, history([0.99] * 10), 1000, 0.97)
    t.record(FREE, history([0.9] * 10), 1000, 0.96)
    v = t.verdict()
    assert v.winner == STATIC and "simplest" in v.reason
    assert [r.candidate for r in v.rows] == ["static", "rigid", "free"]
    assert v.rows[0].verdict == "winner" and "simpler" in v.rows[2].verdict


def test_a_clearly_better_complex_candidate_wins():
    t = Tournament(1000, 100, CONF)
    t.record(STATIC, history([1.0] * 10), 1000, 1.0)
    t.record(FREE, history([0.5] * 10), 1000, 0.5)
    v = t.verdict()
    assert v.winner == FREE and v.rows[0].verdict.startswith("held-out misfit +100")


def test_pruned_candidates_cannot_win():
    t = Tournament(1000, 100, CONF)
    t.record(STATIC, history([1.0] * 10), 1000, 1.0)
    t.record(RIGID, history([2.0, 2.0, 2.0]), 300, 0.1)  # stopped: its (late) misfit is not comparable
    assert t.verdict().winner == STATIC


def test_a_failed_fit_is_pruned_with_its_reason_and_cannot_win():
    t = Tournament(1000, 100, CONF)
    t.record(STATIC, [], 0, math.inf, failed="diverged: stage 'static_fit' diverged at step 100")
    t.record(RIGID, history([2.0] * 10), 1000, 2.0)
    v = t.verdict()
    assert v.winner == RIGID and v.rows[0].verdict.startswith("diverged: stage 'static_fit'")


def test_no_finished_candidate_is_an_error():
    with pytest.raises(ValueError, match="no candidate finished"):
        Tournament(10, 100, CONF).verdict()


@pytest.mark.parametrize("kwargs, key", [({"rungs": []}, "motion.rungs"), ({"rungs": ["wobbly"]}, "motion.rungs"),
                                         ({"rungs": ["free", "free"]}, "motion.rungs"),
                                         ({"first_budget": 0}, "first_budget"), ({"tolerance": -0.1}, "motion.tolerance"), ({"milestone_margin": -0.01}, "motion.milestone_margin"),
                                         ({"band_f_max": 0.0}, "motion.band_f_max"),
                                         ({"scene_budget": 1.5}, "motion.scene_budget")])
def test_bad_settings_are_named(kwargs, key):
    with pytest.raises(ValueError, match=key):
        SelectionConf(**kwargs)


K1, K2, K3, K2_IMAGE = SceneModel(1), SceneModel(2), SceneModel(3), SceneModel(2, "image")


def test_scene_models_are_compared_at_the_same_rung_by_the_scene_tolerance():
    """A freer scene model must lead a simpler one at the same rung by ``scene_tolerance`` to go on; a simpler
    one may trail by as much; another scene model's other rungs set no bound."""
    t = Tournament(1000, 100, replace(CONF, scene_tolerance=0.1))
    t.record(Candidate(K1, "free"), history([1.0] * 10), 1000, 1.0)
    two = Candidate(K2, "free")
    assert t.stops(two)(history([0.95] * 5)) and not t.stops(two)(history([0.9] * 5))
    assert not t.stops(Candidate(K2, "static"))(history([9.0] * 5))  # K1's free fit says nothing of K2's static
    t2 = Tournament(1000, 100, replace(CONF, scene_tolerance=0.1))
    t2.record(Candidate(K2_IMAGE, "free"), history([1.0] * 10), 1000, 1.0)
    assert not t2.stops(Candidate(K2, "free"))(history([1.09] * 5)) and t2.stops(Candidate(K2, "free"))(history([1.11] * 5))


def test_scene_models_are_compared_from_the_scene_budget_on():
    """Before ``scene_budget`` x steps a fit is not stopped for trailing another scene model (a model with more
    objects starts further from its end), only for trailing its own model's candidates."""
    t = Tournament(1000, 100, replace(CONF, scene_tolerance=0.1, scene_budget=0.5))
    t.record(Candidate(K1, "free"), history([1.0] * 10), 1000, 1.0)
    t.record(Candidate(K2, "free"), history([3.0] * 10), 1000, 3.0)
    two = Candidate(K2, "free", start=1)
    assert not t.stops(Candidate(K3, "free"))(history([9.0] * 3))  # step 300: no scene model compared yet
    assert t.stops(Candidate(K3, "free"))(history([9.0] * 5))  # step 500: far behind K1's
    assert t.stops(two)(history([4.0] * 3))  # 33 % behind its own model's other start: compared from the first
    early = Tournament(1000, 100, replace(CONF, scene_budget=0.0))
    early.record(Candidate(K1, "free"), history([1.0] * 10), 1000, 1.0)
    assert early.stops(Candidate(K3, "free"))(history([9.0] * 3))


def test_the_simplest_scene_model_within_its_tolerance_wins_then_its_simplest_rung():
    conf = replace(CONF, scene_tolerance=0.1)
    t = Tournament(1000, 100, conf)
    t.record(Candidate(K2, "free"), history([1.0] * 10), 1000, 1.0)
    t.record(Candidate(K2_IMAGE, "free"), history([0.95] * 10), 1000, 0.95)
    t.record(Candidate(K2, "rigid"), history([1.02] * 10), 1000, 1.02)
    v = t.verdict()
    assert v.winner == Candidate(K2, "rigid") and "scene model k2_none" in v.reason
    assert v.rows[1].verdict.startswith("scene model k2_image") and v.rows[1].background == "image"
    t.record(Candidate(K1, "free"), history([2.0] * 10), 1000, 2.0)
    assert t.verdict().winner == Candidate(K2, "rigid")  # one object explains the views far worse
    t.record(Candidate(SceneModel(3, "image"), "free"), history([0.5] * 10), 1000, 0.5)
    assert t.verdict().winner.scene == SceneModel(3, "image")  # a clearly better freer model wins
