"""The turn warning's limit (issue 50) tuned on turning ellipses whose fits are scored.

A run warns "the moving object turns with the gantry" where the turning object's own frame is seen over less
than a limit of view angle (``turn_coverage_deg`` in metrics.json, read off the views' second moments;
moments/determinacy.py). Here ellipses turning about the centre at rates that leave their own frame 160° down to
20° of view angle are reconstructed by the default ``nct`` and by FBP, each in its own process, and each fit is
scored against the truth (warning_rates.py's "poor"); each scan's coverage is read as a run reads it. For each
candidate limit: warned, justified (the truth's coverage under 180° and the fit poor), false alarms and misses,
as warning_rates.py counts them.

    python benchmarks/diagnostics/turn_warning.py [--out DIR] [--jobs 2] [--rates 200 250 ...] [--resume]

With ``--files DIR --scores scenes.csv`` it runs nothing: the coverage of each ``<scene>.npz`` of a generalisation
table, read as a run with nothing passed reads it, set against that table's scores and truth.
"""

from __future__ import annotations

import csv
import json
import sys
import time
from collections.abc import Sequence
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parent))
from init_candidates import run_config  # noqa: E402
from scene_model_files import RUN  # noqa: E402
from warning_rates import TURNS, Run, classify, row_run  # noqa: E402

from nct.analysis.benchmarking import QUIET, Job, Record, benchmark_parser, run_jobs  # noqa: E402
from nct.moments.determinacy import TURN_WARN_DEG, turn_coverage  # noqa: E402
from nct.run.outcome import FINISHED  # noqa: E402
from nct.run.pipeline import acquire  # noqa: E402
from nct.run.tables import markdown_table, write_csv  # noqa: E402

SHAPES = {"bar": (0.35, 0.06), "ellipse": (0.30, 0.22)}  # semi-axes (field of view): the bar experiment's, and
# a fatter one (generalisation's scene032, the one turn warning of its 100 scenes, is 30 x 22.5 % of its field)
RATES = (200, 225, 250, 270, 290, 315, 340)  # deg per rotation, with the gantry: own frame seen over 360 - rate
LIMITS_DEG = (20, 30, 45, 60, 75, 80, 90, 100, 120, 150, 180)  # the candidate limits scored
METHODS = ("nct", "fbp")


def plan(out: Path, shapes: Sequence[str], rates: Sequence[float], seed: int) -> list[Job]:
    """One job per shape, rate and method: the bar experiment with the shape's axes and the turn ``rate``."""
    jobs = []
    for shape in shapes:
        a, b = SHAPES[shape]
        for rate in rates:
            scene = ("experiment=bar", f"phantom.objects.0.a.value={a}", f"phantom.objects.0.b.value={b}",
                     f"phantom.objects.0.angle_deg.rate={rate:g}")
            jobs += [Job({"shape": shape, "rate": rate}, m, seed, (*scene, *QUIET),
                         out / "runs" / shape / f"{rate:g}" / m) for m in METHODS]
    return jobs


def coverage_deg(path: Path | None, overrides: Sequence[str]) -> float:
    """The coverage of the file at ``path`` (None: the ``overrides``' simulated scene) as a run reads it
    (`turn_coverage`; NaN: no axis held)."""
    conf = run_config(path, None, [o for o in overrides if o not in QUIET])
    coverage = turn_coverage(acquire(conf, np.random.default_rng(conf.seed)).sinogram)
    return float("nan") if coverage is None else coverage


def file_pairs(files: Path, scores: Path) -> list[tuple[Run, float]]:
    """Each scored row of ``scores`` whose file ``files`` holds, with the file's coverage."""
    with open(scores, newline="") as fh:
        rows = [r for r in csv.DictReader(fh) if (files / f"{r['scene']}.npz").is_file()]
    if not rows:
        raise SystemExit(f"turn_warning: error: {files}: holds no <scene>.npz of {scores}")
    return [(row_run(r), coverage_deg(files / f"{r['scene']}.npz", RUN)) for r in rows]


def scored(nct: Record, fbp: Record) -> tuple[Run, float]:
    """The NCT run as warning_rates' `Run` (truth: one object turning at the job's rate over one rotation, the
    gantry counter-clockwise; the warnings its status.json holds) and the scan's coverage."""
    status = json.loads((nct.job.run_dir / "status.json").read_text()) if nct.status == "ok" else {}
    run = Run("", f"{nct.job.labels['shape']}_{nct.job.labels['rate']:g}", "nct", FINISHED if nct.status == "ok"
              else nct.status, tuple(status.get("warnings", ())), nct.dice, fbp.dice, nct.mse, fbp.mse,
              (TURNS[0],), (float(nct.job.labels["rate"]),), 1.0, 1, "")
    return run, coverage_deg(None, nct.job.overrides)


def run_rows(pairs: Sequence[tuple[Run, float]], runs: bool) -> list[dict]:
    """One row per run (``runs``; else per file seen over less than 180 deg): its scores, the coverage measured
    and, for runs, whether the run warned of the turn (with the code it ran)."""
    return [{"run": r.scene, "coverage_deg": f"{c:.0f}", "nct_dice": f"{r.nct_dice:.4f}",
             "fbp_dice": f"{r.fbp_dice:.4f}", "nct_mse": f"{r.nct_mse:.3g}", "fbp_mse": f"{r.fbp_mse:.3g}",
             "poor": r.poor}
            | ({"warned_when_run": any(classify(w) == "turn" for w in r.warnings)} if runs else {})
            for r, c in pairs if runs or c < 180]


def limit_rows(pairs: Sequence[tuple[Run, float]]) -> list[dict]:
    """Per candidate limit (TURN_WARN_DEG marked): warned (coverage below it), justified, false alarms, misses."""
    rows = []
    for limit in LIMITS_DEG:
        warned = [c < limit for _, c in pairs]
        justified = [r.turns_unseen() and r.poor for r, _ in pairs]
        rows.append({"limit_deg": f"{limit:g}{' (today)' if limit == TURN_WARN_DEG else ''}", "runs": len(pairs),
                     "warned": sum(warned), "justified": sum(justified),
                     "false_alarms": sum(w and not j for w, j in zip(warned, justified)),
                     "misses": sum(j and not w for w, j in zip(warned, justified))})
    return rows


def main(argv: Sequence[str] | None = None) -> int:
    parser = benchmark_parser("turn_warning", __doc__.split("\n\n")[0], "the bar only", seeds=None)
    parser.add_argument("--rates", type=float, nargs="+", default=RATES, help="turns, deg per rotation")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--files", type=Path, help="folder of <scene>.npz (with --scores: no run)")
    parser.add_argument("--scores", type=Path, help="generalisation.py's scenes.csv for --files")
    args = parser.parse_args(argv)
    started = time.perf_counter()
    files = args.files is not None or args.scores is not None
    if files and (args.files is None or args.scores is None):
        parser.error("--files and --scores go together (a table's files read, no run)")
    if files and not args.scores.is_file():
        parser.error(f"--scores {args.scores}: no such table")
    if files:
        pairs = file_pairs(args.files, args.scores)
    else:
        jobs = plan(args.out, ["bar"] if args.quick else list(SHAPES), args.rates, args.seed)
        records = run_jobs(jobs, args.jobs, args.resume, args.timeout, args.threads)
        pairs = [scored(n, f) for n, f in zip(records[::2], records[1::2])]
    runs, limits = run_rows(pairs, not files), limit_rows(pairs)
    args.out.mkdir(parents=True, exist_ok=True)
    write_csv(runs, args.out / "turn_warning.csv")
    command = "python benchmarks/diagnostics/turn_warning.py " + " ".join(sys.argv[1:] if argv is None else argv)
    text = (f"# The turn warning's limit\n\nCommand: `{command}` ({(time.perf_counter() - started) / 60:.1f} min)\n\n"
            + (markdown_table(list(runs[0]), [list(r.values()) for r in runs]) if runs else "No file under 180 deg.")
            + "\n\n"
            + markdown_table(list(limits[0]), [list(r.values()) for r in limits]) + "\n")
    (args.out / "turn_warning.md").write_text(text)
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
