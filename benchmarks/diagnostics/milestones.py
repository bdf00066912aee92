"""Would the tournament's milestones have stopped the eventual winner? Replays runs whose fits all ran to
the end (``--override motion.first_budget=1``: no milestones) through the tournament's schedule with
``--first-budget`` (``motion.first_budget``), ``--margin`` (``motion.milestone_margin``) and ``--scene-budget``
(``motion.scene_budget``) and prints, per run, each fit it would stop (where, how far behind what it needed, its
final held-out misfit against the best), whether the winner changes and, where the run's folder holds the scene's
truth (a generalisation benchmark's scenes.csv), whether the winner's K is the truth's.

Fits are independent (each candidate's own random streams), so a replayed run chooses as the run with
milestones would have, and where it chooses the same winner its reconstruction is the same.

    python benchmarks/generalisation.py --size 128 --subset --jobs 2 --threads 1 --out outputs/noprune \
        --override motion.first_budget=1
    python benchmarks/diagnostics/milestones.py outputs/noprune --margin 0 0.05 --scene-budget 0.25 0.5 \
        --first-budget 0.1 0.25
"""

from __future__ import annotations

import argparse
import csv
import json
import math
from pathlib import Path

from nct.fields.conf import RUNGS
from nct.select.candidates import Candidate, SceneModel
from nct.select.conf import SelectionConf
from nct.select.tournament import Tournament


def fits(run: Path) -> tuple[int, int, list[tuple[Candidate, list[tuple[int, float]], int, float]]] | None:
    """A run's fit steps, held-out check interval and fits in the order they ran: (candidate, held-out
    history, steps, final misfit); None for a run without a tournament (no metrics.json -> selection). A rung
    the run did not fit (select/stillness.py) is left out."""
    metrics = json.loads((run / "metrics.json").read_text())
    if "selection" not in metrics:
        return None
    table, stages = metrics["selection"]["table"], metrics["stages"]
    if any("n_objects" not in row for row in table):
        raise ValueError(f"{run} was written by an older nct (its selection table names no candidate's model): "
                         "rerun it")
    table = [row for row in table if f"{row['candidate']}_fit" in stages]  # a rung a still scan left out: no fit
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


def replay(steps: int, every: int, ran: list, margin: float, scene_budget: float,
           first_budget: float = SelectionConf.first_budget) -> tuple[Candidate, int, list[str]]:
    """The winner, the steps fitted and a line per stopped fit, were the first milestone at ``first_budget`` of the
    steps, the milestones at ``margin`` and scene models compared from ``scene_budget`` on."""
    tournament = Tournament(steps, every, SelectionConf(rungs=list(RUNGS), first_budget=first_budget,
                                                       milestone_margin=margin, scene_budget=scene_budget))
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
    return tournament.verdict().winner, used, lines


def label(setting: tuple[float, float, float]) -> str:
    """A replayed schedule's name: its margin, scene budget and first budget."""
    return f"margin {setting[0]:g}, scene budget {setting[1]:g}, first budget {setting[2]:g}"


def truth_models(root: Path) -> dict[str, SceneModel]:
    """Each scene's model (its objects, no background) from a generalisation folder's scenes.csv; {} without."""
    table = root / "scenes.csv"
    if not table.exists():
        return {}
    with table.open(newline="") as f:
        return {row["scene"]: SceneModel(int(row["n_objects"])) for row in csv.DictReader(f)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("root", type=Path, help="a benchmark's output folder (its runs' metrics.json below it)")
    parser.add_argument("--margin", type=float, nargs="+", default=[0.0, 0.05], help="milestone margins to replay")
    parser.add_argument("--scene-budget", type=float, nargs="+", default=[0.5],
                        help="shares of the steps from which scene models are compared to replay")
    parser.add_argument("--first-budget", type=float, nargs="+", default=[SelectionConf.first_budget],
                        help="shares of the steps at which the first milestone falls to replay")
    args = parser.parse_args()
    if min(args.margin) < 0 or not all(0 <= b <= 1 for b in args.scene_budget + args.first_budget):
        parser.exit(2, "milestones: error: --margin must be >= 0, --scene-budget and --first-budget in [0, 1]\n")
    try:
        runs = {p.parent: fits(p.parent) for p in sorted(args.root.rglob("metrics.json"))}
    except ValueError as err:
        parser.exit(2, f"milestones: error: {err}\n")
    runs = {run: found for run, found in runs.items() if found is not None}
    if not runs:
        parser.exit(2, f"milestones: error: no run with a tournament (metrics.json -> selection) below {args.root}\n")
    truth = truth_models(args.root)
    settings = [(m, b, f) for m in args.margin for b in args.scene_budget for f in args.first_budget]
    totals = {key: [0, 0, 0] for key in [None, *settings]}  # steps, the winner unchanged, the truth's model chosen
    for run, (steps, every, ran) in runs.items():
        if any(done < steps for _, _, done, m in ran if math.isfinite(m)):
            parser.exit(2, f"milestones: error: {run} stopped fits early: rerun it with motion.first_budget=1\n")
        model = truth.get(run.parent.name)
        everyone = replay(steps, 0, ran, 0.0, 0.0, 1.0)
        print(f"{run.relative_to(args.root)}: {len(ran)} fits, all finished: {everyone[0].name} ({everyone[1]} steps)"
              + (f"; the truth's model {model.label}" if model else ""))
        for key in [None, *settings]:
            winner, used, lines = everyone if key is None else replay(steps, every, ran, *key)
            totals[key] = [totals[key][0] + used, totals[key][1] + (winner == everyone[0]),
                           totals[key][2] + (winner.scene == model)]
            if key is not None:
                same = "the same winner" if winner == everyone[0] else f"{winner.name} wins instead"
                print(f" {label(key)}: {same}, {used} steps", *lines, sep="\n")
    print(f"\n{len(runs)} runs" + (", the truth's model known" if truth else ""))
    for key, (used, same, right) in totals.items():
        name = "no milestones" if key is None else label(key)
        print(f" {name}: {used} steps, the winner of no milestones on {same}"
              + (f", the truth's model on {right}" if truth else ""))


if __name__ == "__main__":
    main()
