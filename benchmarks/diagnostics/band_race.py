"""What the band race (``capacity.band_race_at``, ``band_race_gain``) decides on a generalisation
call's runs, from the held-out history of both first passes, and the band fit time it saves.

Each run that tried the temporal band holds the held-out loss of the configured fit and of the
wider band's fit at every check (``metrics.json`` -> ``stages`` -> ``heldout_history``; for runs
made before that record existed, their ``logger=csv`` logs). A band fit the race stops leaves the
run bit for bit as without the band, and one it lets go on is not touched, so the race's outcome
on a call whose bands all ran to the end follows from these histories alone. Written by hand: no
library replays a stopping rule on logged curves.

    python benchmarks/diagnostics/band_race.py --call outputs/benchmarks/gen_seed1 --at 0.2 0.3 0.4 --gain 0.8 0.9 1.0
"""

from __future__ import annotations

import argparse
import csv
import json
import statistics
import sys
from dataclasses import replace
from pathlib import Path

from nct.method.capacity import CapacityConf, band_kept
from nct.method.race import HeldoutHistory, lost
from nct.method.reconstruct import BAND_PREFIX


def kept_fit(stages: dict, prefix: str) -> str:
    """The name of a pass's kept SinogramFit attempt (``fit``, ``fit_retry1``, ...)."""
    return next(name for name, s in stages.items() if name.startswith(prefix + "fit") and s.get("kept"))


def history(run: Path, stages: dict, name: str) -> HeldoutHistory:
    """Stage ``name``'s held-out history: its record's, else its CSV log's (Lightning logs a
    validation at the step before the one the stage counts)."""
    if "heldout_history" in stages[name]:
        return [(int(step), float(loss)) for step, loss in stages[name]["heldout_history"]]
    with (run / "csv" / name / "metrics.csv").open() as f:
        return [(int(r["step"]) + 1, float(r["val/heldout_loss"])) for r in csv.DictReader(f) if r["val/heldout_loss"]]


def replay_args(argv: list[str] | None, doc: str, at: float | None, gain: float) -> argparse.Namespace:
    """A replay's command line: ``--call`` (a generalisation call's folder) and the race rules to replay,
    every ``--at`` with every ``--gain`` (default: the configured ``at``, ``gain``)."""
    parser = argparse.ArgumentParser(description=doc.split("\n\n")[0])
    parser.add_argument("--call", type=Path, required=True, help="a generalisation.py --out folder")
    parser.add_argument("--at", type=float, nargs="+", default=[at])
    parser.add_argument("--gain", type=float, nargs="+", default=[gain])
    return parser.parse_args(argv)


def main(argv: list[str] | None = None) -> int:
    args = replay_args(argv, __doc__, CapacityConf().band_race_at, CapacityConf().band_race_gain)
    runs = []
    for metrics in sorted(args.call.glob("runs/*/nct/metrics.json")):
        m = json.loads(metrics.read_text())
        band = m.get("capacity", {}).get("band")
        if not band:
            continue
        stages, run = m["stages"], metrics.parent
        ours, wide = (history(run, stages, kept_fit(stages, p)) for p in ("", BAND_PREFIX))
        steps = int(stages[kept_fit(stages, "")]["steps"])  # the configured fit ran them all; a raced band fit may not
        band_time = sum(float(s["wall_time_s"]) for name, s in stages.items() if name.startswith(BAND_PREFIX))
        fit = stages[kept_fit(stages, BAND_PREFIX)]
        # Time a rule could save: only that of a band fit that ran to the end (a raced one stopped already).
        full = float(fit["wall_time_s"]) if int(fit["steps"]) == steps else 0.0
        runs.append((run.parent.name, ours, wide, steps, band_kept(band), full, band_time,
                     float(m["wall_time_s"])))
    if not runs:
        print(f"band_race: error: no finished run in {args.call}/runs tried the temporal band", file=sys.stderr)
        return 1
    print(f"{len(runs)} runs tried the band; each line: the wider fit's held-out loss over the configured fit's "
          "at each check, and whether the band was kept")
    for scene, ours, wide, _, kept, *_ in runs:
        mine = dict(ours)
        print(f"  {scene}: " + " ".join(f"{loss / mine[step]:.2f}" for step, loss in wide if step in mine)
              + ("  kept" if kept else ""))
    print("| race_at | race_gain | band fits stopped | at steps | kept bands stopped | saved of the band passes' time "
          "| run / run without the band, median: as run -> with this rule |")
    print("|---|---|---|---|---|---|---|")
    for at in args.at:
        for gain in args.gain:
            conf = replace(CapacityConf(), band_race_at=at, band_race_gain=gain)
            times, stops = [], []
            for scene, ours, wide, steps, kept, full, band_time, run_time in runs:
                race = conf.band_race(wide, ours, steps)
                stopped = lost(race)
                times.append((run_time, band_time, (1 - race["step"] / steps) * full if stopped else 0.0))
                stops += [(scene, race["step"], kept)] if stopped else []
            print(rule_row(at, gain, [f"{len(stops)}/{len(runs)}", ", ".join(str(s) for _, s, _ in stops),
                                      ", ".join(s for s, _, k in stops if k) or "none"], times))
    return 0


def rule_row(at: float, gain: float, cells: list[str], times: list[tuple[float, float, float]]) -> str:
    """A row of a race rule's table: ``at``, ``gain`` and ``cells``, then, from each run's (run time, time
    of the fits the rule races, time it saves of them), the time saved of the raced fits' and the median
    ratio of the run's time to its time without those fits, as run -> with the rule."""
    saved, raced = sum(s for _, _, s in times), sum(r for _, r, _ in times)
    before = [run / (run - r) for run, r, _ in times]
    after = [(run - s) / (run - r) for run, r, s in times]
    return (f"| {at:g} | {gain:g} | " + " | ".join(cells) + f" | {saved:.0f} of {raced:.0f} s | "
            f"{statistics.median(before):.2f} -> {statistics.median(after):.2f} |")


if __name__ == "__main__":
    raise SystemExit(main())
