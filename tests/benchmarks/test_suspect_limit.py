"""benchmarks/diagnostics/suspect_limit.py: the suspect-fit limit scored against the truth over runs on disk."""

import json

from tests.conftest import load_benchmark

S = load_benchmark("diagnostics/suspect_limit")


def metrics(folder, held, nct_dice, fbp_dice, nct_mse=1e-4, fbp_mse=1e-3):
    """A run folder's metrics.json: held-out misfits (NCT, FBP, noise) and the truth's median scores."""
    folder.mkdir(parents=True)
    nct, fbp, noise = held
    (folder / "metrics.json").write_text(json.dumps({
        "heldout_loss": nct, "heldout_fbp_loss": fbp, "heldout_noise_loss": noise,
        "nct": {"median_dice": nct_dice, "median_mse": nct_mse},
        "fbp": {"median_dice": fbp_dice, "median_mse": fbp_mse}}))


def test_each_limit_counts_false_alarms_and_misses_of_distinct_runs(tmp_path):
    metrics(tmp_path / "a" / "good_fast", (0.037, 0.032, 0.005), 0.996, 0.911)  # 1.19x, good
    metrics(tmp_path / "b" / "good_fast_copy", (0.037, 0.032, 0.005), 0.996, 0.911)  # the same run again
    metrics(tmp_path / "a" / "told_too_few", (0.058, 0.039, 0.0), 0.936, 0.997, 3.6e-2, 3e-3)  # 1.49x, poor
    metrics(tmp_path / "a" / "short", (0.25, 0.1, 0.0), 0.9, 0.8, 5e-2, 4e-2)  # 2.5x and 0.25 unexplained: poor (MSE)
    metrics(tmp_path / "a" / "quiet_poor", (0.02, 0.04, 0.0), 0.7, 0.9)  # 0.5x, poor
    (tmp_path / "a" / "fbp_only").mkdir()
    (tmp_path / "a" / "fbp_only" / "metrics.json").write_text(json.dumps({"fbp": {"median_dice": 0.9}}))
    runs = S.read_runs([tmp_path])
    assert len(runs) == 4 and [r.poor for r in runs] == [False, True, True, True]
    got = {(row["limit"], row["lines"]): (row["warned"], row["false alarms"], row["poor"], row["misses"])
           for limit in (1.0, 1.25, 2.0) for row in S.tally(runs, limit, excess=0.1)}
    assert got[1.0, "ratio"] == (3, 1, 3, 1)
    assert got[1.25, "ratio"] == (2, 0, 3, 1)
    assert got[2.0, "ratio"] == (1, 0, 3, 2) and got[2.0, "ratio or excess"] == (1, 0, 3, 2)
    assert S.main([str(tmp_path), "--out", str(tmp_path / "out")]) == 0
    assert "| 1.25 | ratio | 4 | 2 | 0 | 3 | 1 |" in (tmp_path / "out" / "suspect_limit.md").read_text()
