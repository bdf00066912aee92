"""Warnings as a classifier (benchmarks/warning_rates.py, issue 50): every line the warning functions write
is told its kind, and on hand-made benchmark folders each kind's false alarms and misses are counted
against the truth as the definitions say."""

from __future__ import annotations

import csv
import json
import math
from types import SimpleNamespace

import numpy as np
import pytest

from nct.acquisition.times import slow_rotation_warning
from nct.moments.determinacy import MotionDeterminacy, determinacy_warnings, turn_warnings
from nct.run.conf import SuspectConf
from nct.run.consistency import FanSwing, GeometryCheck, OffsetEstimate, geometry_warnings
from nct.run.suspect import suspect_warnings
from nct.run.tables import write_csv
from nct.select.misfits import HeldoutMisfits
from tests.conftest import load_benchmark

W = load_benchmark("warning_rates")

TIMES = slow_rotation_warning(np.linspace(0, 2 * np.pi, 10), np.linspace(0, 100, 10), None)
MOTION = determinacy_warnings(MotionDeterminacy(2.5, 1.0, False, 1.0, 0.1, 0.1))
TURN = turn_warnings(60.0)
OFFSET, FAN = geometry_warnings(
    GeometryCheck(OffsetEstimate(3.0, (3.0,), (0.1,), 0.1), FanSwing(3.0, 2.0, 10.0, (3.0,), (10.0,))),
    SimpleNamespace(geometry=SimpleNamespace(bin_spacing=1.0, field_radius=1.0)), SuspectConf())
EXCESS = suspect_warnings(HeldoutMisfits(0.15, 0.3, 0.0), SuspectConf(), True)  # above excess, below FBP's
ABOVE_FBP = suspect_warnings(HeldoutMisfits(0.05, 0.02, 0.0), SuspectConf(), False)  # above FBP's only


def test_each_warning_function_s_lines_are_told_their_kind():
    lines = {"times": TIMES, "motion": MOTION, "turn": TURN, "offset": [OFFSET], "fan": [FAN],
             "suspect_excess": EXCESS, "suspect_fbp": ABOVE_FBP}
    for kind, written in lines.items():
        assert len(written) == 1 and W.classify(written[0]) == kind, (kind, written)
    both = suspect_warnings(HeldoutMisfits(0.5, 0.1, 0.0), SuspectConf(), False)
    assert [W.classify(w) for w in both] == ["suspect_fbp", "suspect_excess"]
    assert W.classify("the scan smells odd") == W.OTHER


# scene: motions, deg/rot, rotations, gantry sense, NCT and FBP Dice, NCT and FBP MSE, status, warnings
SCENES = {
    "s0": ("orbit", "200", 3, "ccw", 0.99, 0.95, 1e-4, 1e-3, "ok", MOTION),  # good: a false alarm
    "s1": ("translation static", "150 0", 1, "ccw", 0.6, 0.5, 1e-3, 2e-3, "ok", MOTION + EXCESS),  # poor (< 0.8)
    "s2": ("rotation", "190", 1, "ccw", 0.85, 0.9, 1e-3, 2e-3, "ok", []),  # poor; its frame seen over 170 deg
    "s3": ("rotation", "190", 1, "cw", 0.85, 0.9, 1e-3, 2e-3, "ok", TURN + ABOVE_FBP),  # poor; seen over 550 deg
    "s4": ("static", "0", 2, "ccw", 0.99, 0.98, 1e-4, 1e-3, "ok", TIMES + [OFFSET]),  # good
    "s5": ("orbit", "100", 1, "ccw", math.nan, 0.9, math.nan, 1e-3, "failed", []),  # not scored
    "s6": ("beat", "100", 2, "ccw", 0.97, 0.96, 3e-3, 2e-3, "ok", [FAN, "the scan smells odd"]),  # poor: MSE
}


def status(run_dir, state, warnings):
    run_dir.mkdir(parents=True)
    (run_dir / "status.json").write_text(json.dumps({"status": state, "error": None, "warnings": warnings}))


@pytest.fixture
def folders(tmp_path):
    """A generalisation folder of SCENES and a textured one (one poor orbit, over a background image)."""
    gen, tex = tmp_path / "gen", tmp_path / "tex"
    rows = []
    for scene, (motions, deg, rot, sense, nd, fd, nm, fm, state, warnings) in SCENES.items():
        rows.append({"scene": scene, "motions": motions, "deg_per_rotation": deg, "rotations": rot, "direction": sense,
                     "noise_i0": "", "nct_dice": nd, "fbp_dice": fd, "nct_mse": nm, "fbp_mse": fm})
        status(gen / "runs" / scene / "nct", state, warnings)
    write_csv(rows, gen / "scenes.csv")
    write_csv([{"family": "holes", "scene": "holes000", "background": "image", "motions": "orbit", "noise_i0": 1e5,
                "nct_own_dice": 0.7, "fbp_own_dice": 0.9, "nct_mse": 1e-3, "fbp_mse": 2e-3}], tex / "textured.csv")
    status(tex / "runs" / "holes000" / "image", "ok", MOTION)
    return gen, tex


def test_rates_count_false_alarms_and_misses_against_the_truth(folders):
    verdicts = [W.judge(r) for f in folders for r in W.read_folder(f)]
    got = {t.name: (t.runs, t.warned, t.justified, t.false_alarms, t.misses) for t in W.tallies(verdicts)}
    assert got == {"times": (7, 1, 0, 1, 0), "motion": (7, 3, 2, 1, 0), "turn": (7, 1, 1, 1, 1),
                   "offset": (7, 1, 0, 1, 0), "fan": (7, 1, 0, 1, 0), "suspect_fbp": (7, 1, 5, 0, 4),
                   "suspect_excess": (7, 1, 5, 0, 4), "geometry (either)": (7, 2, 0, 2, 0),
                   "suspect fit (either)": (7, 2, 5, 0, 3), "any warning / poor fit": (7, 6, 5, 2, 1)}
    motion = next(t for t in W.tallies(verdicts) if t.name == "motion")
    assert motion.false_alarm_rate == pytest.approx(1 / 3) and motion.miss_rate == 0.0
    times = next(t for t in W.tallies(verdicts) if t.name == "times")
    assert times.false_alarm_rate == 1.0 and math.isnan(times.miss_rate)


def test_the_script_writes_one_row_per_run_and_the_tables(folders, tmp_path):
    out = tmp_path / "out"
    assert W.main([str(f) for f in folders] + ["--out", str(out)]) == 0
    with open(out / "warnings.csv", newline="") as fh:
        rows = {(r["folder"], r["scene"]): r for r in csv.DictReader(fh)}
    assert len(rows) == 8
    assert rows["gen", "s2"]["turn"] == "miss" and rows["gen", "s3"]["turn"] == "false alarm"
    assert rows["gen", "s1"]["motion"] == "hit" and rows["gen", "s1"]["suspect_fbp"] == "miss"
    assert rows["gen", "s5"]["status"] == "failed" and rows["gen", "s5"]["warned"] == ""
    assert rows["gen", "s6"]["poor"] == "True" and rows["gen", "s6"]["other"] == "the scan smells odd"
    assert rows["tex", "holes000"]["motion"] == "hit"
    text = (out / "warnings.md").read_text()
    assert "| motion | 7 | 3 | 2 | 1 | 0.333 | 0 | 0 |" in text
    assert "| motion | 6 | 2 | 1 | 1 | 0.5 | 0 | 0 |" in text  # the generalisation folder's own table
    assert "gen/s5/nct (failed)" in text and "``motion`` (moments/determinacy.py)" in text


def test_a_folder_without_a_benchmark_table_is_refused_in_one_line(tmp_path):
    with pytest.raises(SystemExit, match="no scenes.csv or textured.csv"):
        W.read_folder(tmp_path)
