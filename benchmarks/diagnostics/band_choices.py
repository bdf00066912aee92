"""Assemble a generalisation report of the temporal band rule (``capacity.band_f_max``) from two
earlier calls of ``generalisation.py``, one at the configured band and one at the wider band.

A run that keeps the wider band is, bit for bit, the run configured at that band (same random
streams; ``tests/test_band.py``), and a run that does not is the run at the configured band. So
each scene's run folder is copied from the call the rule picks, by the held-out losses both
runs recorded; ``generalisation.py --resume --out OUT`` then writes the report. The wall times
of such a report are those of one pass: the plain command at the band rule's code gives the same
Dice and MSE and the real time.

    python benchmarks/diagnostics/band_choices.py --narrow outputs/benchmarks/gen_seed1_starts \
        --wide outputs/benchmarks/gen_seed1_fmax05_all --out outputs/benchmarks/gen_seed1_band
"""

from __future__ import annotations

import argparse
import csv
import json
import shutil
import sys
from pathlib import Path

from nct.acquisition.io import load_sinogram
from nct.method.capacity import CapacityConf
from nct.method.conf import ModelConf
from nct.method.prepare import rotations_spanned


def heldout(call: Path, scene: str) -> float | None:
    """The held-out loss a call's run of ``scene`` recorded (None: no finished run)."""
    path = call / "runs" / scene / "nct" / "metrics.json"
    return json.loads(path.read_text())["heldout_loss"] if path.is_file() else None


def spanned(call: Path, scene: str) -> float:
    """Rotations the views of a call's run of ``scene`` span (the sinogram file the run wrote)."""
    return rotations_spanned(load_sinogram(call / "runs" / scene / "nct" / "sinogram.npz"))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--narrow", type=Path, required=True, help="the call at the configured model.f_max")
    parser.add_argument("--wide", type=Path, nargs="+", required=True,
                        help="calls at model.f_max = capacity.band_f_max (the first that ran a scene is used)")
    parser.add_argument("--out", type=Path, required=True, help="a new folder; its runs/ are the copies")
    args = parser.parse_args(argv)
    capacity, f_max = CapacityConf(), ModelConf().f_max
    (args.out / "runs").mkdir(parents=True)
    rows, choices = list(csv.DictReader((args.narrow / "scenes.csv").open())), []
    for row in rows:
        scene, source = row["scene"], args.narrow
        narrow = heldout(args.narrow, scene)
        if narrow is not None and capacity.tries_band(f_max, spanned(args.narrow, scene), ModelConf().n_terms, True):
            wide = next(((c, h) for c in args.wide if (h := heldout(c, scene)) is not None), None)
            if wide is None:
                print(f"band_choices: error: no run of {scene} at the wider band in {args.wide}", file=sys.stderr)
                return 1
            keep = capacity.keeps_band(narrow, wide[1])
            choices.append([scene, narrow, wide[1], wide[1] / narrow, keep, wide[0].name])
            source = wide[0] if keep else args.narrow
        shutil.copytree(source / "runs" / scene, args.out / "runs" / scene)
    with (args.out / "band_choices.csv").open("w", newline="") as f:
        csv.writer(f).writerows([["scene", f"heldout_fmax{f_max:g}", f"heldout_fmax{capacity.band_f_max:g}",
                                  "ratio", "kept_wider", "wide_call"], *choices])
    print(f"{len(choices)} scenes tried the wider band, {sum(c[4] for c in choices)} kept it: {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
