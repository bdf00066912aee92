"""benchmarks/diagnostics/milestones.py: a run whose fits all ran to the end, replayed through the tournament's
schedule: a start far behind stops at the first milestone, wherever ``--first-budget`` puts it."""

from __future__ import annotations

import json

from tests.conftest import load_benchmark

milestones = load_benchmark("diagnostics/milestones")


def test_a_start_far_behind_stops_at_the_first_milestone_replayed(tmp_path):
    steps = list(range(100, 1001, 100))
    ahead = [0.01 * 1000 / s for s in steps]
    table, stages = [], {}
    for name, start, history in [("free", 0, ahead), ("free_start1", 1, [2 * x for x in ahead])]:
        table.append({"candidate": name, "n_objects": 1, "background": "none", "rung": "free", "f_max": None,
                      "start": start, "turning": None, "restart": False, "steps": 1000, "heldout_misfit": history[-1]})
        stages[f"{name}_fit"] = {"planned_steps": 1000, "heldout_history": [list(p) for p in zip(steps, history)]}
    (tmp_path / "metrics.json").write_text(json.dumps({"selection": {"table": table}, "stages": stages}))
    n_steps, every, ran = milestones.fits(tmp_path)
    assert (n_steps, every, [c.name for c, *_ in ran]) == (1000, 100, ["free", "free_start1"])
    assert milestones.replay(n_steps, 0, ran, 0.05, 0.5, 1.0)[1] == 2000  # no milestones: both to the end
    for first, stop in [(0.25, 300), (0.1, 100)]:
        winner, used, lines = milestones.replay(n_steps, every, ran, 0.05, 0.5, first)
        assert winner.name == "free" and used == 1000 + stop and f"stopped at step {stop}" in lines[0]
