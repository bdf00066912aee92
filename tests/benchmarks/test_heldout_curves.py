"""benchmarks/diagnostics/heldout_curves.py: each finished fit's held-out misfit over its last, and how many a stop
at each check would leave behind; fits cut short and InitFits are left out."""

from __future__ import annotations

import json

import pytest

from tests.conftest import load_benchmark

heldout_curves = load_benchmark("diagnostics/heldout_curves")


def test_a_fit_still_falling_at_a_check_counts_as_behind_there(tmp_path):
    run = tmp_path / "run"
    run.mkdir()
    falling = [[100, 0.4], [200, 0.205], [300, 0.2]]
    stages = {"free_fit": {"steps": 300, "planned_steps": 300, "heldout_history": falling},
              "rigid_fit": {"steps": 100, "planned_steps": 300, "heldout_history": [[100, 0.3]]},  # stopped early
              "free_init": {"steps": 300, "planned_steps": 300}}
    (run / "metrics.json").write_text(json.dumps({"stages": stages}))
    found = heldout_curves.curves([tmp_path])
    assert list(found) == ["run:free_fit"]
    steps, ratios = found["run:free_fit"]
    assert steps == [100, 200, 300] and ratios.tolist() == pytest.approx([2.0, 1.025, 1.0])
    summary = heldout_curves.table(found).splitlines()[-3:]
    assert [line.split("|")[-2].strip() for line in summary] == ["1", "0", "0"]
