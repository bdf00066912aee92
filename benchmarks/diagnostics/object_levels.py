"""How well each method draws a scene's brightest level, on a generalisation call's runs: the mean
of its frames over the pixels where the truth is within ``--within`` of its frame's peak, over the
truth's mean there (1: right; below 1: too faint or spread).

Dice scores shapes at one threshold (half the faintest level), so a small object drawn twice as
wide at half its contrast can score as well as a right one; this ratio sees it. Reads each run's
``reconstruction.npz`` (``nct``, ``fbp``) and the truth in its ``sinogram.npz``; nothing is re-run.

    python benchmarks/diagnostics/object_levels.py --call outputs/benchmarks/gen100 \
        --out benchmarks/results/generalisation/levels.md
"""

from __future__ import annotations

import argparse
import csv
import statistics
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np


def brightest_ratio(truth: np.ndarray, frames: np.ndarray, within: float = 0.02) -> float:
    """mean(frames) / mean(truth) over the pixels of truth [F, H, W] within ``within`` (a share)
    of each truth frame's peak; frames [F, H, W] on the same grid."""
    if truth.shape != frames.shape:
        raise ValueError(f"truth {truth.shape} and frames {frames.shape} differ in shape")
    region = truth >= (1 - within) * truth.max(axis=(1, 2), keepdims=True)
    return float(frames[region].mean() / truth[region].mean())


@dataclass(frozen=True)
class Row:
    """One scene: its layout and radii (scenes.csv) and both methods' brightest-level ratios."""

    scene: str
    layout: str
    radii_pct: str
    nct: float
    fbp: float


def rows(call: Path, within: float) -> list[Row]:
    """Every scene of the call whose NeuralCT run finished, in scenes.csv's order."""
    found = []
    for scene in csv.DictReader((call / "scenes.csv").open()):
        run = call / "runs" / scene["scene"] / "nct"
        if scene["nct_status"] != "ok" or not (run / "reconstruction.npz").exists():
            continue
        frames = np.load(run / "reconstruction.npz")
        truth = np.load(run / "sinogram.npz")["truth"]
        found.append(Row(scene["scene"], scene["layout"], scene["radii_pct"],
                         brightest_ratio(truth, frames["nct"], within), brightest_ratio(truth, frames["fbp"], within)))
    return found


def report(found: list[Row], command: str, margin: float) -> str:
    """Markdown: the medians, the scenes where NCT is further below 1 than FBP by more than ``margin``."""
    worse = [r for r in found if r.nct < r.fbp - margin]
    lines = [f"# The brightest level, NCT and FBP\n\nCommand: `{command}`\n",
             f"{len(found)} scenes. Ratio of the drawn to the true brightest level: median NCT "
             f"{statistics.median(r.nct for r in found):.3f}, FBP {statistics.median(r.fbp for r in found):.3f}; "
             f"below 0.9: NCT {sum(r.nct < 0.9 for r in found)}, FBP {sum(r.fbp < 0.9 for r in found)}.\n",
             f"Scenes where NCT's ratio is more than {margin} below FBP's: {len(worse)}\n",
             "| scene | layout | radii (% of FOV) | NCT | FBP |", "|---|---|---|---|---|"]
    lines += [f"| {r.scene} | {r.layout} | {r.radii_pct} | {r.nct:.3f} | {r.fbp:.3f} |" for r in worse]
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--call", type=Path, required=True, help="a generalisation call's --out folder")
    parser.add_argument("--within", type=float, default=0.02, help="share of the peak that counts as brightest")
    parser.add_argument("--margin", type=float, default=0.05, help="list scenes where NCT is this far below FBP")
    parser.add_argument("--out", type=Path, help="also write the report here (markdown)")
    args = parser.parse_args(argv)
    if not (args.call / "scenes.csv").exists():
        print(f"object_levels: error: no scenes.csv in {args.call}", file=sys.stderr)
        return 1
    found = rows(args.call, args.within)
    if not found:
        print(f"object_levels: error: no finished NeuralCT run in {args.call}", file=sys.stderr)
        return 1
    command = "python benchmarks/diagnostics/object_levels.py " + " ".join(argv if argv is not None else sys.argv[1:])
    text = report(found, command, args.margin)
    print(text)
    if args.out:
        args.out.write_text(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
