"""The motion warning's limit (issue 50) tuned on files whose fits are scored.

A run warns "motion along the rays is not determined" where the spread along the rays between equally good
centroid trajectories (moments/determinacy.py, read off the sinogram alone) exceeds a limit. Here each file's
spread is computed as a run computes it, and set against whether the file's fit was poor and an object's centre
moves (benchmarks/warning_rates.py's definitions, from a benchmark table of scored runs: the truth is read only to
score). For each candidate limit: warned, justified, false alarms and misses, as warning_rates.py counts them.

    python benchmarks/diagnostics/motion_warning.py --files DIR --scores scenes.csv [--out OUT]

DIR holds ``<scene>.npz`` for each row of ``scenes.csv`` (generalisation.py's table: motions, Dice and MSE of NCT
and FBP).
"""

from __future__ import annotations

import argparse
import csv
import sys
import time
from collections.abc import Sequence
from pathlib import Path

import numpy as np
from threadpoolctl import threadpool_limits

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parent))
from init_candidates import run_config  # noqa: E402
from scene_model_files import RUN  # noqa: E402
from warning_rates import CENTRE_MOVES, Run, number  # noqa: E402

from nct.moments.determinacy import motion_determinacy  # noqa: E402
from nct.run.outcome import FINISHED  # noqa: E402
from nct.run.pipeline import acquire  # noqa: E402
from nct.run.tables import markdown_table, write_csv  # noqa: E402

LIMITS_PX = (1.0, 1.5, 2.0, 2.5, 3.0, 4.0, 5.0, 6.0, 8.0)  # the candidate limits scored


def spread_px(path: Path) -> float:
    """The file's spread along the rays (pixels of the run's grid) as a run with nothing passed measures it; NaN
    where the views give no trajectory."""
    conf = run_config(path, None, list(RUN))
    scan = acquire(conf, np.random.default_rng(conf.seed))
    verdict = motion_determinacy(scan.sinogram, scan.grid)
    return float("nan") if verdict is None else verdict.ray_spread_px


def scored(row: dict) -> Run:
    """A scenes.csv row as warning_rates' `Run` (its truth and scores; no warnings: the limit is what is tuned)."""
    return Run("", row["scene"], "nct", FINISHED, (), number(row["nct_dice"]), number(row["fbp_dice"]),
               number(row["nct_mse"]), number(row["fbp_mse"]), tuple(row["motions"].split()), (), number(None), 0,
               row.get("noise_i0", ""))


def file_row(row: dict, spread: float, seconds: float) -> dict:
    """motion_warning.csv's row: the scenes.csv ``row``'s scores, the file's ``spread`` (px) and whether a warning
    is justified there (an object's centre moves and the fit is poor)."""
    run = scored(row)
    return {"scene": row["scene"], "motions": row["motions"], "spread_px": spread, "nct_dice": run.nct_dice,
            "fbp_dice": run.fbp_dice, "poor": run.poor, "justified": run.moves(CENTRE_MOVES) and run.poor,
            "seconds": seconds}


def limits_table(rows: Sequence[dict]) -> str:
    """Per candidate limit: files, warned, justified (centre moves and the fit is poor), false alarms, misses."""
    out = []
    justified = [r["justified"] for r in rows]
    for limit in LIMITS_PX:
        warned = [r["spread_px"] > limit for r in rows]
        hits = sum(w and j for w, j in zip(warned, justified))
        out.append([f"{limit:g}", len(rows), sum(warned), sum(justified), sum(warned) - hits,
                    sum(justified) - hits])
    return markdown_table(["limit px", "files", "warned", "justified", "false alarms", "misses"], out)


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--files", type=Path, required=True, help="folder of <scene>.npz")
    parser.add_argument("--scores", type=Path, required=True, help="generalisation.py's scenes.csv for those files")
    parser.add_argument("--out", type=Path, default=Path("outputs/benchmarks/motion_warning"))
    args = parser.parse_args(argv)
    if not args.scores.is_file():
        raise SystemExit(f"motion_warning: error: {args.scores}: no such table")
    with open(args.scores, newline="") as fh:
        table = [r for r in csv.DictReader(fh) if (args.files / f"{r['scene']}.npz").is_file()]
    if not table:
        raise SystemExit(f"motion_warning: error: {args.files}: holds no <scene>.npz of {args.scores}")
    rows = []
    with threadpool_limits(1):
        for r in table:
            started = time.perf_counter()
            spread = spread_px(args.files / f"{r['scene']}.npz")
            rows.append(file_row(r, spread, time.perf_counter() - started))
    write_csv(rows, args.out / "motion_warning.csv")
    command = "python " + " ".join([Path(sys.argv[0]).as_posix(), *(argv if argv is not None else sys.argv[1:])])
    widest = sorted(rows, key=lambda r: -r["spread_px"])[:10]
    text = "\n".join([
        "# The motion warning's limit", "", f"Command: `{command}`", "", limits_table(rows), "",
        "The widest spreads:", "",
        markdown_table(["scene", "motions", "spread px", "NCT Dice", "FBP Dice", "poor"],
                       [[r["scene"], r["motions"], r["spread_px"], r["nct_dice"], r["fbp_dice"], r["poor"]]
                        for r in widest]), ""])
    (args.out / "motion_warning.md").write_text(text)
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
