"""Are the fits done before their last step? Each finished sinogram fit's held-out misfit at every check, over its
last (issue 48: "fits that stop when they are done"), from the runs' metrics.json (``stages``' held-out histories).

Prints one row per fit that ran all its planned steps, and a summary: per check, the median and the range of the
ratio, and how many fits a stop at that check would leave more than 5 % above their last misfit.
Run: python benchmarks/diagnostics/heldout_curves.py RUN_FOLDER [RUN_FOLDER ...] [--out FILE.md]
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from nct.run.tables import markdown_table

BEHIND = 0.05  # a stop that leaves the held-out misfit this share above its last is a stop too early


def curves(folders: list[Path]) -> dict[str, tuple[list[int], np.ndarray]]:
    """Per finished fit (``<run folder under its folder>:<stage>``), its checks' steps and misfit over its last:
    {name: (steps, ratios)}."""
    found = {}
    for folder, metrics in sorted((folder, p) for folder in folders for p in folder.rglob("metrics.json")):
        try:
            stages = json.loads(metrics.read_text()).get("stages", {})
        except ValueError as err:
            raise ValueError(f"{metrics} is not a run's metrics.json ({err})") from None
        for name, stage in stages.items():
            history = stage.get("heldout_history") if isinstance(stage, dict) else None
            if not history or not name.endswith("_fit") or stage.get("steps") != stage.get("planned_steps"):
                continue
            steps, values = zip(*history)
            run = metrics.parent.relative_to(folder).as_posix()
            found[f"{run}:{name}"] = (list(steps), np.asarray(values) / values[-1])
    return found


def table(found: dict[str, tuple[list[int], np.ndarray]]) -> str:
    """The rows and the summary as markdown (fits whose checks fall on the first fit's steps)."""
    steps = next(iter(found.values()))[0]
    alike = {k: r for k, (s, r) in found.items() if s == steps}
    rows = markdown_table(["fit", *map(str, steps)], [[k, *(f"{x:.3f}" for x in r)] for k, r in alike.items()])
    ratios = np.stack(list(alike.values()))
    behind = (ratios > 1 + BEHIND).sum(axis=0)
    summary = markdown_table(["check", "median", "min", "max", f"fits > {1 + BEHIND:g}"],
                             [[s, f"{np.median(c):.3f}", f"{c.min():.3f}", f"{c.max():.3f}", int(n)]
                              for s, c, n in zip(steps, ratios.T, behind)])
    return (f"{rows}\n\n{len(alike)} fits whose checks fall on steps {steps[0]}..{steps[-1]} "
            f"({len(found) - len(alike)} others left out).\n\n{summary}")


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("folders", type=Path, nargs="+", help="folders holding runs (searched for metrics.json)")
    parser.add_argument("--out", type=Path, help="write the table here too (markdown)")
    args = parser.parse_args(argv)
    try:
        found = curves(args.folders)
    except (OSError, ValueError) as err:
        raise SystemExit(f"heldout_curves: error: {err}") from None
    if not found:
        raise SystemExit("heldout_curves: no finished fit with a held-out history under " +
                         ", ".join(map(str, args.folders)))
    text = table(found)
    print(text)
    if args.out:
        args.out.write_text(text)


if __name__ == "__main__":
    main()
