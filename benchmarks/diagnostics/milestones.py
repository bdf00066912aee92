"""Would the tournament's milestones have stopped the eventual winner? Replays runs whose fits all ran to
the end (``--override motion.first_budget=1``: no milestones) through the tournament's schedule with
``--margin`` (``motion.milestone_margin``) and prints, per run, each fit it would stop (where, how far
behind what it needed, its final held-out misfit against the best) and whether the winner changes.

Fits are independent (each candidate's own random streams), so a replayed run chooses as the run with
milestones would have, and where it chooses the same winner its reconstruction is the same.

    python benchmarks/generalisation.py --size 128 --subset --jobs 2 --threads 1 --out outputs/noprune \
        --override motion.first_budget=1
    python benchmarks/diagnostics/milestones.py outputs/noprune --margin 0 0.05
"""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path

from nct.fields.conf import RUNGS
from nct.select.candidates import Candidate, SceneModel
from nct.select.conf import SelectionConf
from nct.select.tournament import Tournament

FIRST_BUDGET = 0.25  # the schedule replayed: the default motion.first_budget


def fits(run: Path) -> tuple[int, int, list[tuple[Candidate, list[tuple[int, float]], int, float]]] | None:
    """A run's fit steps, held-out check interval and fits in the order they ran: (candidate, held-out
    history, steps, final misfit); None for a run without a tournament (no metrics.json -> selection)."""
    metrics = json.loads((run / "metrics.json").read_text())
    if "selection" not in metrics:
        return None
    table, stages = metrics["selection"]["table"], metrics["stages"]
    if any("n_objects" not in row for row in table):
        raise ValueError(f"{run} was written by an older nct (its selection table names no candidate's model): rerun it")
    named = len({(row["n_objects"], row["background"]) for row in table}) > 1
    out = []
    for row in table:
        cand = Candidate(SceneModel(row["n_objects"], row["background"]), row["rung"], row["start"], row["f_max"],
                         row["turning"], row["restart"], named)
        history = [(int(step), float(loss))
                   for step, loss in stages.get(f"{row['candidate']}_fit", {}).get("heldout_history", [])]
        out.append((cand, history, int(row["steps"]), float(row["heldout_misfit"])))
    steps = max(stages[f"{row['candidate']}_fit"].get("planned_steps", 0) for row in table)
    every = min((b[0] - a[0] for _, h, _, _ in out for a, b in zip(h, h[1:])), default=0)
    return steps, every, out


def replay(steps: int, every: int, ran: list, margin: float) -> tuple[str, int, list[str]]:
    """The winner, the steps fitted and a line per stopped fit, were the milestones at ``margin``."""
    tournament = Tournament(steps, every, SelectionConf(rungs=list(RUNGS), first_budget=FIRST_BUDGET,
                                                       milestone_margin=margin))
    best = min((m for *_, m in ran if math.isfinite(m)), default=math.inf)
    used, lines = 0, []
    for cand, history, done, misfit in ran:
        cut = next((i for i in range(1, len(history) + 1) if tournament.verdict_at(cand, history[:i])), None)
        if cut is None:
            used += done
            tournament.record(cand, history, done, misfit, None if math.isfinite(misfit) else "failed")
            continue
        step, loss = history[cut - 1]
        used += step
        lines.append(f"  {cand.name} stopped at step {step}, {loss / tournament.to_win_at(cand, step) - 1:+.1%} "
                     f"behind; it would have ended at {misfit:.4g} ({misfit / best - 1:+.1%} against the best)")
        tournament.record(cand, history[:cut], step, loss)
    return tournament.verdict().winner.name, used, lines


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("root", type=Path, help="a benchmark's output folder (its runs' metrics.json below it)")
    parser.add_argument("--margin", type=float, nargs="+", default=[0.0, 0.05], help="milestone margins to replay")
    args = parser.parse_args()
    if min(args.margin) < 0:
        parser.exit(2, f"milestones: error: --margin must be >= 0, got {min(args.margin)}\n")
    try:
        runs = {p.parent: fits(p.parent) for p in sorted(args.root.rglob("metrics.json"))}
    except ValueError as err:
        parser.exit(2, f"milestones: error: {err}\n")
    runs = {run: found for run, found in runs.items() if found is not None}
    if not runs:
        parser.exit(2, f"milestones: error: no run with a tournament (metrics.json -> selection) below {args.root}\n")
    for run, (steps, every, ran) in runs.items():
        if any(done < steps for _, _, done, m in ran if math.isfinite(m)):
            parser.exit(2, f"milestones: error: {run} stopped fits early: rerun it with motion.first_budget=1\n")
        everyone = replay(steps, 0, ran, 0.0)
        print(f"{run.relative_to(args.root)}: {len(ran)} fits, all finished: {everyone[0]} ({everyone[1]} steps)")
        for margin in args.margin:
            winner, used, lines = replay(steps, every, ran, margin)
            same = "the same winner" if winner == everyone[0] else f"{winner} wins instead"
            print(f" margin {margin:g}: {same}, {used} steps", *lines, sep="\n")


if __name__ == "__main__":
    main()
