"""Stability: where FBP and NeuralCT break down, against motion, noise and view count.

Maps Dice (median, quartiles and range over seeds) of both methods against displacement per
rotation, Poisson noise I0 and views per rotation on the moving circle, each run in its own ``nct``
process (nct.analysis.benchmarking). A run that fails, diverges, times out or scores NaN counts as Dice 0 and
as a failure. The breakdown point is the first setting (easy to hard) with median Dice < 0.85.
Writes runs.csv, summary.csv, breakdown.csv, stability.png and stability.md.

Run: python benchmarks/stability.py [--out DIR] [--quick] [--axes full|quick] [--axis NAME ...] [--seeds 0 1 2 3 4]
     [--jobs N] [--override KEY=VALUE ...]
"""

from __future__ import annotations

import sys
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.ticker import NullFormatter  # noqa: E402

from nct.analysis.benchmark_stats import breakdown_point, group, median_ok, seed_stats  # noqa: E402
from nct.analysis.benchmarking import QUIET, Job, Record, benchmark_parser, default_config, run_jobs, scaled_steps  # noqa: E402
from nct.run.metrics import DICE_GOOD  # noqa: E402
from nct.run.tables import markdown_table, write_csv  # noqa: E402

METHODS = ("fbp", "nct")
QUICK_DATA = ("image.size=64", "scanner.n_bins=64")  # --quick: a quarter of the pixels, for both methods


@dataclass(frozen=True)
class Axis:
    """One stress axis: config ``key`` set to ``values`` (ordered easy to hard) on top of ``base``."""

    name: str
    key: str
    label: str
    values: tuple
    base: tuple[str, ...] = ()
    log: bool = False

    def overrides(self, value: object) -> tuple[str, ...]:
        return (*self.base, f"{self.key}={value}")


def axes(quick: bool, base_displacement: float) -> list[Axis]:
    """Displacement per rotation 0-360 degrees; Poisson I0 1e6 down to 1e3 and on to 1; views per
    rotation 720 down to 90 and on to 4 (FBP of the circle at 40 degrees still scores 0.93 at 1e3
    photons and at 90 views, 0.90 at 10 of either: the extensions look for the breakdown). Noise
    and views vary the circle at ``base_displacement`` degrees per rotation."""
    circle = ("experiment=circle",)
    base = (*circle, f"phantom.displacement_deg={base_displacement:g}")
    values = {"displacement": (0, 100, 200), "noise": (1e6, 1e3, 30), "views": (720, 90, 20)} if quick else {
        "displacement": (0, 45, 90, 135, 180, 270, 360), "noise": (1e6, 1e5, 1e4, 1e3, 3e2, 1e2, 30, 10, 3, 1),
        "views": (720, 360, 180, 90, 45, 20, 10, 6, 4)}
    return [Axis("displacement", "phantom.displacement_deg", "displacement per rotation [deg]",
                 values["displacement"], circle),
            Axis("noise", "data.noise_i0", "Poisson I0 [photons per ray]", values["noise"], base, log=True),
            Axis("views", "scanner.views_per_rotation", "views per rotation", values["views"], base, log=True)]


def plan(out: Path, stress: Sequence[Axis], seeds: Sequence[int], nct: Sequence[str] = (),
         extra: Sequence[str] = ()) -> list[Job]:
    """One job per axis, setting, method and seed; ``nct``: extra overrides of the NeuralCT runs."""
    return [Job({"axis": a.name, "setting": v}, m, seed, (*a.overrides(v), *(nct if m == "nct" else ()), *QUIET,
                                                         *extra),
                out / "runs" / a.name / m / f"{v:g}" / f"seed{seed}")
            for a in stress for v in a.values for m in METHODS for seed in seeds]


def summarise(records: Sequence[Record]) -> list[dict]:
    """One row per (axis, setting, method): Dice over seeds, failures as 0, and the failure count."""
    rows = []
    for (axis, setting, method), recs in group(records, ("axis", "setting", "method")).items():
        s = seed_stats(recs)
        rows.append({"axis": axis, "setting": setting, "method": method, "runs": s.n, "failed": s.n_failed,
                     "dice_median": s.median, "dice_q25": s.q25, "dice_q75": s.q75, "dice_min": s.min,
                     "dice_max": s.max, "mse_median": median_ok(recs, "mse")})
    return rows


def breakdowns(rows: Sequence[dict], stress: Sequence[Axis]) -> list[dict]:
    """Each method's breakdown point on each axis (None: held up everywhere)."""
    out = []
    for a in stress:
        for m in METHODS:
            mine = [r for r in rows if r["axis"] == a.name and r["method"] == m]
            out.append({"axis": a.name, "method": m, "breakdown": breakdown_point(
                [r["setting"] for r in mine], [r["dice_median"] for r in mine])})
    return out


def plot(rows: Sequence[dict], points: Sequence[dict], stress: Sequence[Axis], path: Path) -> Path:
    """Per axis: median Dice per method, its IQR (dark band) and range (light band) over seeds,
    failures as crosses with their count, breakdown points as dashed lines. Harder to the right."""
    fig, panels = plt.subplots(1, len(stress), figsize=(5 * len(stress), 4), squeeze=False)
    for ax, a in zip(panels[0], stress):
        for i, m in enumerate(METHODS):
            mine = [r for r in rows if r["axis"] == a.name and r["method"] == m]
            x = [r["setting"] for r in mine]
            colour = f"C{i}"
            ax.plot(x, [r["dice_median"] for r in mine], "o-", color=colour, label=f"{m.upper()} median")
            ax.fill_between(x, [r["dice_q25"] for r in mine], [r["dice_q75"] for r in mine], color=colour, alpha=0.3)
            ax.fill_between(x, [r["dice_min"] for r in mine], [r["dice_max"] for r in mine], color=colour, alpha=0.1)
            for r in mine:
                if r["failed"]:
                    ax.plot([r["setting"]], [0.02], "x", color=colour)
                    ax.annotate(f"{r['failed']}/{r['runs']} failed", (r["setting"], 0.02), fontsize=7, color=colour,
                                textcoords="offset points", xytext=(3, 4 + 10 * i))
            point = next(p["breakdown"] for p in points if p["axis"] == a.name and p["method"] == m)
            if point is not None:
                ax.axvline(point, ls="--", color=colour, lw=1, label=f"{m.upper()} breakdown: {point:g}")
        ax.axhline(DICE_GOOD, color="grey", lw=0.5)
        ax.set(xlabel=a.label, ylabel="Dice over seeds", ylim=(0, 1.02), title=a.name)
        if a.log:
            ax.set_xscale("log")
            ax.xaxis.set_minor_formatter(NullFormatter())
        ax.set_xticks(a.values, [f"{v:g}" for v in a.values], rotation=45 if a.log else 0)
        if a.values[0] > a.values[-1]:
            ax.invert_xaxis()
        ax.legend(fontsize=7, loc="lower left")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def report(rows: Sequence[dict], points: Sequence[dict], stress: Sequence[Axis], command: str,
           elapsed_s: float) -> str:
    """The markdown note: breakdown points, then one table per axis."""
    def cell(r: dict) -> str:
        return (f"{r['dice_median']:.3f} [{r['dice_q25']:.3f}–{r['dice_q75']:.3f}] "
                f"({r['dice_min']:.3f}–{r['dice_max']:.3f}) {r['failed']}/{r['runs']}")

    def shown(p: object) -> str:
        return "none (≥ 0.85 everywhere)" if p is None else f"{p:g}"

    parts = ["# Stability", "", f"Command: `{command}` (this call: {elapsed_s / 60:.1f} min).", "",
             "Dice over seeds: median [quartiles] (min–max) failed/runs; a failed, diverged, timed-out or NaN "
             f"run counts as Dice 0. Breakdown: the first setting (easy to hard) with median Dice < {DICE_GOOD}.",
             "", markdown_table(["axis", *[f"{m.upper()} breakdown" for m in METHODS]],
                                [[a.name, *[shown(p["breakdown"]) for m in METHODS for p in points
                                            if p["axis"] == a.name and p["method"] == m]] for a in stress])]
    for a in stress:
        mine = [r for r in rows if r["axis"] == a.name]
        settings = list(dict.fromkeys(r["setting"] for r in mine))
        table = [[f"{v:g}", *[cell(r) for m in METHODS for r in mine if r["setting"] == v and r["method"] == m]]
                 for v in settings]
        parts += ["", f"## {a.name}: {a.label}" + (f" (on {' '.join(a.base)})" if a.base else ""), "",
                  markdown_table([a.key, *[m.upper() for m in METHODS]], table)]
    return "\n".join(parts) + "\n"


def run_benchmark(out: Path, stress: Sequence[Axis], seeds: Sequence[int], nct: Sequence[str] = (),
                  n_jobs: int = 1, resume: bool = False, extra: Sequence[str] = (), command: str = "",
                  timeout_s: float | None = None, threads: int = 1) -> tuple[list[dict], list[dict]]:
    """Run every job, then write the outputs (`write_outputs`); returns the summary rows and breakdown points."""
    start = time.perf_counter()
    records = run_jobs(plan(out, stress, seeds, nct, extra), n_jobs, resume, timeout_s, threads)
    return write_outputs(out, records, stress, command, time.perf_counter() - start)


def write_outputs(out: Path, records: Sequence[Record], stress: Sequence[Axis], command: str,
                  elapsed_s: float) -> tuple[list[dict], list[dict]]:
    """runs.csv, summary.csv, breakdown.csv, stability.png and stability.md into ``out``."""
    rows = summarise(records)
    points = breakdowns(rows, stress)
    write_csv([r.row() for r in records], out / "runs.csv")
    write_csv(rows, out / "summary.csv")
    write_csv(points, out / "breakdown.csv")
    plot(rows, points, stress, out / "stability.png")
    (out / "stability.md").write_text(report(rows, points, stress, command, elapsed_s))
    return rows, points


def main(argv: Sequence[str] | None = None) -> None:
    parser = benchmark_parser("stability", __doc__.split("\n\n")[0],
                              "3 settings per axis, 2 seeds, 64-pixel images, a tenth of the NeuralCT steps",
                              "default: 0 1 2 3 4 (quick: 0 1)")
    parser.add_argument("--axes", choices=("full", "quick"),
                        help="settings per axis: full (7-8 per axis) or quick (3); default quick with --quick, else full")
    parser.add_argument("--axis", action="append", choices=("displacement", "noise", "views"),
                        help="run only this axis (repeatable; default: all three)")
    parser.add_argument("--base-displacement", type=float, default=40.0,
                        help="degrees per rotation of the circle on the noise and views axes (default 40)")
    parser.add_argument("--override", action="append", default=[], metavar="KEY=VALUE",
                        help="an nct override added to every NeuralCT run (repeatable), e.g. motion=auto")
    args = parser.parse_args(argv)
    seeds = args.seeds or ([0, 1] if args.quick else [0, 1, 2, 3, 4])
    nct = (*(scaled_steps(default_config(), 0.1) if args.quick else ()), *args.override)
    extra = QUICK_DATA if args.quick else ()
    command = "python benchmarks/stability.py " + " ".join(sys.argv[1:] if argv is None else argv)
    quick_axes = args.quick if args.axes is None else args.axes == "quick"
    stress = [a for a in axes(quick_axes, args.base_displacement) if not args.axis or a.name in args.axis]
    run_benchmark(args.out, stress, seeds, nct, args.jobs, args.resume, extra,
                  command=command.strip(), timeout_s=args.timeout, threads=args.threads)
    print((args.out / "stability.md").read_text())
    print(f"outputs in {args.out}")


if __name__ == "__main__":
    main()
