"""benchmarks/diagnostics/motion_warning.py: the motion warning's limit scored on files whose fits are scored."""

from __future__ import annotations

import csv
import math

import numpy as np
import pytest

from tests.conftest import load_benchmark

MW = load_benchmark("diagnostics/motion_warning")
S = load_benchmark("scenes")
F = load_benchmark("scene_files")


def row(scene: str, motions: str, nct: float, fbp: float) -> dict:
    return {"scene": scene, "motions": motions, "nct_dice": str(nct), "fbp_dice": str(fbp), "nct_mse": "0.001",
            "fbp_mse": "0.01"}


def test_limits_count_false_alarms_and_misses():
    """A warning is justified where the centre moves and the fit is poor: a good orbit over the limit is a false
    alarm, a poor orbit under it a miss, a poor still scene justifies nothing."""
    rows = [MW.file_row(r, s, 0.0) for s, r in ((3.0, row("a", "orbit", 0.99, 0.5)),
                                                (0.5, row("b", "orbit", 0.7, 0.6)),
                                                (9.0, row("c", "static", 0.5, 0.9)))]
    table = MW.limits_table(rows)
    assert "| 2 | 3 | 2 | 1 | 2 | 1 |" in table  # warned a and c, justified b: two false alarms, one miss
    assert "| 4 | 3 | 1 | 1 | 1 | 1 |" in table


def test_spreads_of_written_files(tmp_path):
    """The spread of a file as a run reads it: a still scene reads 0 px; the table and note are written."""
    scene = next(s for s in S.draw_scenes(0, 40) if {o.motion.kind for o in s.objects} == {"static"})
    F.write_scene(scene, tmp_path / "files" / f"{scene.name}.npz", 32, 4, 0)
    scores = tmp_path / "scenes.csv"
    with open(scores, "w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=list(row("", "", 0, 0)))
        writer.writeheader()
        writer.writerows([row(scene.name, "static", 0.99, 0.98), row("absent", "orbit", 0.5, 0.9)])
    assert MW.main(["--files", str(tmp_path / "files"), "--scores", str(scores), "--out", str(tmp_path / "out")]) == 0
    with open(tmp_path / "out" / "motion_warning.csv", newline="") as fh:
        (written,) = list(csv.DictReader(fh))
    assert written["scene"] == scene.name and abs(float(written["spread_px"])) < 0.05
    assert math.isfinite(float(written["spread_px"])) and (tmp_path / "out" / "motion_warning.md").is_file()
    assert np.isclose(float(written["nct_dice"]), 0.99)


def test_a_folder_without_the_tables_files_is_named(tmp_path, capsys):
    scores = tmp_path / "scenes.csv"
    scores.write_text("scene,motions,nct_dice,fbp_dice,nct_mse,fbp_mse\nx,orbit,1,1,0,0\n")
    with pytest.raises(SystemExit) as stop:
        MW.main(["--files", str(tmp_path / "none"), "--scores", str(scores), "--out", str(tmp_path / "out")])
    assert "none" in str(stop.value) and "no <scene>.npz" in str(stop.value) and not (tmp_path / "out").exists()
