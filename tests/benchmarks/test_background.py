"""benchmarks/background.py: a tiny call runs the thorax over a background and tables the whole image and
the heart's parts at their own levels."""

from __future__ import annotations

import csv

from tests.conftest import TINY, load_benchmark

B = load_benchmark("background")


def test_a_tiny_call_tables_the_whole_image_and_the_hearts_parts(tmp_path, capsys):
    out = tmp_path / "call"
    # TINY's scene keys left out: the benchmark sets K and the background itself (last, they would override them)
    tiny = [o for o in TINY if not o.startswith(("data.n_objects=", "background="))]
    overrides = [arg for o in tiny + ["threads=1"] for arg in ("--override", o)]
    B.main(["--out", str(out), "--quick", *overrides])
    with open(out / "runs.csv") as fh:
        rows = list(csv.DictReader(fh))
    assert [(r["experiment"], r["background"], r["seed"], r["status"]) for r in rows] == [("thorax", "image", "0", "ok")]
    with open(out / "thorax_image" / "seed0" / "selection.csv") as fh:  # the run fitted what the row says
        assert {(r["n_objects"], r["background"]) for r in csv.DictReader(fh)} == {("2", "image")}
    row = rows[0]
    assert float(row["fbp_mse"]) > 0 and float(row["mse_ratio"]) == float(row["nct_mse"]) / float(row["fbp_mse"])
    assert all(0 <= float(row[k]) <= 1 for k in ("fbp_heart", "nct_heart", "fbp_pool", "nct_pool"))
    text = (out / "background.md").read_text()
    assert "| thorax | image | 0 | ok |" in text and "Median over seeds:" in text
    assert "background.md" in capsys.readouterr().out
