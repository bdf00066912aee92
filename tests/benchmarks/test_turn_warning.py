"""benchmarks/diagnostics/turn_warning.py: the turn warning's limit scored on turning ellipses and files."""

import math

import pytest

from tests.conftest import load_benchmark

TW = load_benchmark("diagnostics/turn_warning")
W = load_benchmark("warning_rates")


def _run(rate: float, nct_dice: float, fbp_dice: float) -> "W.Run":
    return W.Run("", f"bar_{rate:g}", "nct", "ok", (), nct_dice, fbp_dice, 1e-3, 2e-3, ("rotation",), (rate,), 1.0,
                 1, "")


def test_limits_count_warned_justified_false_alarms_and_misses():
    """Seen over 160 deg and good, 70 deg and poor (Dice under 0.8), 110 deg and poor, 90 deg and good, no axis:
    at 80 deg one hit, one miss (110), no false alarm; at 100 one false alarm (90) more."""
    pairs = [(_run(200, 0.99, 0.4), 160.0), (_run(290, 0.06, 0.0), 70.0), (_run(250, 0.89, 0.91), 110.0),
             (_run(270, 0.9, 0.0), 90.0), (_run(0, 0.99, 0.9), math.nan)]
    rows = {r["limit_deg"].split()[0]: r for r in TW.limit_rows(pairs)}
    assert (rows["80"]["warned"], rows["80"]["justified"], rows["80"]["false_alarms"], rows["80"]["misses"]) == (
        1, 2, 0, 1)
    assert (rows["100"]["warned"], rows["100"]["false_alarms"], rows["100"]["misses"]) == (2, 1, 1)
    assert rows["180"]["warned"] == 4 and rows["80"]["limit_deg"] == "80 (today)"
    assert [r["run"] for r in TW.run_rows(pairs, runs=False)] == ["bar_200", "bar_290", "bar_250", "bar_270"]


def test_a_sweep_plans_one_nct_and_one_fbp_run_per_shape_and_rate(tmp_path):
    jobs = TW.plan(tmp_path, ["bar", "ellipse"], [200, 300], seed=0)
    assert [(j.labels["shape"], j.labels["rate"], j.method) for j in jobs[:2]] == [("bar", 200, "nct"),
                                                                                  ("bar", 200, "fbp")]
    assert len(jobs) == 8 and "phantom.objects.0.angle_deg.rate=300" in jobs[-1].overrides


def test_files_without_their_scores_table_is_a_one_line_error_not_a_sweep(tmp_path, capsys):
    for argv in (["--files", str(tmp_path)], ["--files", str(tmp_path), "--scores", str(tmp_path / "no.csv")]):
        with pytest.raises(SystemExit) as stop:
            TW.main([*argv, "--out", str(tmp_path / "out")])
        assert stop.value.code == 2 and "error: --" in capsys.readouterr().err
    assert not (tmp_path / "out").exists()
