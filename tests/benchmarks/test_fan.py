"""benchmarks/fan.py: its own simulation of the circle experiment in fan beam agrees with nct's, its files
load with the intended geometry, and its report scores NCT and FBP per geometry."""

from __future__ import annotations

import csv
import json

import numpy as np
import pytest

from nct.acquisition.geometry import FanGeometry
from nct.acquisition.io import load_sinogram
from nct.acquisition.scanner import ImageGrid, Scanner
from nct.analysis.benchmarking import Job, Record, save_record
from nct.scenes.phantoms import CircleConf, build_phantom
from tests.conftest import closed_form_sinogram, rel_l2
from tests.conftest import load_benchmark as load_script

fan = load_script("fan")


@pytest.mark.parametrize("index", [0, 1, 2], ids=["flat", "curved", "flat-offset"])
def test_files_hold_the_circle_experiment_in_the_intended_geometry(tmp_path, index):
    det = fan.detectors(32)[index]
    sino = load_sinogram(fan.write_file(det, tmp_path / "f.npz", 32, 60, 4))
    geometry = FanGeometry(det.n_bins, det.bin_spacing, 2.0, 2.0, det.shape, det.offset)
    assert sino.geometry == geometry
    if det.offset == 0:  # nct's scanner=fan default detector is the same one
        assert geometry == FanGeometry.covering(0.5, 32, 2.0, 2.0, det.shape)
    # The script's chords against the tests' own closed form (same 8 rays a bin): measured 2.8e-8 (float32).
    scanner = Scanner(60, 1.0, 0.25, 0.0, **{"n_bins": det.n_bins, **geometry.keys()})
    phantom = build_phantom(CircleConf(), scanner.rotation_time)
    expected = np.stack([closed_form_sinogram(geometry, sino.angles[v : v + 1],
                                              phantom.ellipses(sino.times[v : v + 1])[0], sub_rays=8)[0]
                         for v in range(sino.n_views)])
    assert rel_l2(sino.values, expected) < 1e-6
    # And against nct's simulation, whose fan bins are strips of parallel lines: 0.34 % at 32 bins (0.1 % at 128).
    assert rel_l2(sino.values, phantom.project(scanner, ImageGrid(32))) < 5e-3
    np.testing.assert_allclose(sino.truth.frames, phantom.frames(sino.truth.times, ImageGrid(32)), atol=1e-6)


def test_report_scores_nct_and_fbp_per_geometry_and_counts_failures(tmp_path):
    records = []
    for name, seed, status, nct, fbp in [("flat", 0, "ok", 0.95, 0.84), ("flat", 1, "ok", 0.93, 0.85),
                                         ("curved", 0, "ok", 0.94, 0.9), ("curved", 1, "failed", None, None)]:
        run = tmp_path / "runs" / name / f"seed{seed}"
        run.mkdir(parents=True)
        (run / "status.json").write_text(json.dumps({"status": status, "error": None}))
        if status == "ok":
            summary = {"median_dice": 0, "median_mse": 0.001}
            (run / "metrics.json").write_text(json.dumps({"wall_time_s": 10.0, "nct": summary | {"median_dice": nct},
                                                          "fbp": summary | {"median_dice": fbp}}))
        record = Record(Job({"geometry": name}, "nct", seed, (), run), status, dice=nct or np.nan, mse=0.001)
        save_record(record)
        records.append(record)
    fan.write_report(tmp_path, records, "python benchmarks/fan.py --quick", 60.0, 32)
    rows = {r["geometry"]: r for r in csv.DictReader(open(tmp_path / "fan.csv"))}
    assert float(rows["flat"]["nct_dice"]) == pytest.approx(0.94) and float(rows["flat"]["fbp_dice"]) == 0.845
    assert rows["flat"]["passed"] == "True"
    assert float(rows["curved"]["nct_dice"]) == pytest.approx(0.47) and rows["curved"]["nct_failed"] == "1"
    assert rows["curved"]["passed"] == "False"
    assert (tmp_path / "fan.md").read_text().splitlines()[2].startswith("Command: `python benchmarks/fan.py --quick`")
