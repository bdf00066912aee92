"""Speed against accuracy: FBP and NeuralCT configurations of increasing budget on seven scenes.

Each (scene, configuration, seed) runs in its own ``nct`` process (nct.analysis.benchmarking). Writes
runs.csv, summary.csv, accuracy_vs_time.png (Pareto front per scene), params_vs_accuracy.png
and speed_accuracy.md (table and the headline: time to median Dice >= 0.90 on circle at 100
degrees, our default against the paper-sized model, measured or extrapolated to 5000 steps).

Run: python benchmarks/speed_accuracy.py [--out DIR] [--quick] [--seeds 0 1 2] [--jobs N]
"""

from __future__ import annotations

import math
import sys
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from omegaconf import DictConfig  # noqa: E402

from nct.analysis.benchmark_stats import extrapolate_time, group, median_ok, pareto_front, seed_stats  # noqa: E402
from nct.analysis.benchmarking import (  # noqa: E402
    QUIET,
    Job,
    Record,
    benchmark_parser,
    default_config,
    positive_int,
    run_jobs,
    scaled_steps,
    stage_steps,
)
from nct.run.metrics import DICE_GOOD  # noqa: E402
from nct.run.tables import fmt, markdown_table, write_csv  # noqa: E402

SCENES: dict[str, tuple[str, ...]] = {
    "circle_40": ("experiment=circle", "phantom.displacement_deg=40"),
    "circle_100": ("experiment=circle", "phantom.displacement_deg=100"),
    "circle_150": ("experiment=circle", "phantom.displacement_deg=150"),
    "bar": ("experiment=bar",),
    "heart_cine": ("experiment=heart_cine",),
    "letters": ("experiment=letters",),
    "static": ("experiment=static",),
}
QUICK_SCENES = ("circle_100",)
HEADLINE_SCENE, HEADLINE_DICE = "circle_100", 0.90
PAPER_STEPS = 5000  # the paper's maxIterations, for Algorithms 3 and 4 alike (Sec. V)


@dataclass(frozen=True)
class Config:
    """A method configuration. reference: the paper's design, not ours. extrapolate_steps: its time is
    also extrapolated to that many steps per stage, per step from the slope against the run of
    configuration ``short`` (same settings, fewer steps). n_seeds: run only the first n seeds."""

    name: str
    method: str
    overrides: tuple[str, ...] = ()
    reference: bool = False
    extrapolate_steps: int | None = None
    short: str | None = None
    n_seeds: int | None = None


def configs(defaults: DictConfig, quick: bool, paper_steps: int) -> list[Config]:
    """FBP, then NeuralCT of increasing budget (steps x the defaults, field size), the explicit grid
    family (half and full steps), each motion rung alone (the default: the static rung or the free one, as the views say) and
    the motion ladder chosen from the data (grid and default family), then the paper's model
    (with refinement, as in the paper) at a tenth of ``paper_steps`` and at ``paper_steps`` steps per
    stage, first seed only: its time, extrapolated to the paper's steps, is the point."""
    factors = (0.1, 0.25) if quick else (0.25, 0.5, 1.0, 2.0)
    ladder = [Config("nct-default" if f == 1 else f"nct-x{f:g}", "nct", () if f == 1 else scaled_steps(defaults, f))
              for f in factors]
    small = [] if quick else [Config("nct-small", "nct", ("model=siren_small",))]
    rungs = [] if quick else [Config(f"nct-{r}", "nct", (f"motion={r}",)) for r in ("static", "rigid", "affine", "free")]
    grids = [Config("grid-x0.5", "nct", ("model=grid", *scaled_steps(defaults, 0.5))),
             Config("grid", "nct", ("model=grid",)), Config("grid-auto", "nct", ("model=grid", "motion=auto")),
             Config("nct-auto", "nct", ("motion=auto",))]

    def paper(steps: int, **kw) -> Config:
        return Config(f"paper-{steps}steps", "nct", ("model=paper", "optim.refine=true",
                                                     *stage_steps(defaults, steps)), reference=True, n_seeds=1, **kw)

    short = paper(max(1, paper_steps // 10))
    return [Config("fbp", "fbp"), *ladder, *small, *rungs, *([] if quick else grids), short,
            paper(paper_steps, extrapolate_steps=PAPER_STEPS, short=short.name)]


def plan(out: Path, scenes: dict[str, Sequence[str]], cfgs: Sequence[Config], seeds: Sequence[int],
         extra: Sequence[str] = ()) -> list[Job]:
    """One job per scene, configuration and seed, each in ``out/runs/<scene>/<config>/seed<s>``."""
    return [Job({"scene": s, "config": c.name}, c.method, seed, (*scene, *c.overrides, *QUIET, *extra),
                out / "runs" / s / c.name / f"seed{seed}")
            for s, scene in scenes.items() for c in cfgs for seed in seeds[:c.n_seeds]]


def summarise(records: Sequence[Record], cfgs: Sequence[Config]) -> list[dict]:
    """One row per (scene, configuration): Dice over seeds (failures as 0), medians of the rest,
    the extrapolated time of the paper-sized reference and whether the row is on its scene's Pareto front."""
    by_name = {c.name: c for c in cfgs}
    groups = group(records, ("scene", "config"))
    rows = []
    for (scene, name), recs in groups.items():
        stats = seed_stats(recs)
        config = by_name[name]
        row = {"scene": scene, "config": name, "method": config.method, "runs": stats.n, "failed": stats.n_failed,
               "dice_median": stats.median, "dice_min": stats.min, "dice_max": stats.max,
               "mse_median": median_ok(recs, "mse"), "run_time_s": median_ok(recs, "run_time_s"),
               "wall_time_s": median_ok(recs, "wall_time_s"), "peak_mem_mib": median_ok(recs, "peak_mem_mib"),
               "n_params": median_ok(recs, "n_params"), "rungs": chosen_rungs(recs), "reference": config.reference,
               "time_extrapolated_s": extrapolated_time(recs, groups.get((scene, config.short), []),
                                                        config.extrapolate_steps)}
        rows.append(row)
    for scene in dict.fromkeys(r["scene"] for r in rows):
        mine = [r for r in rows if r["scene"] == scene]
        front = pareto_front([r["run_time_s"] for r in mine], [r["dice_median"] for r in mine])
        for i, r in enumerate(mine):
            r["pareto"] = i in front
    return rows


def chosen_rungs(records: Sequence[Record]) -> str:
    """The motion rung each successful run chose (``model.motion``), e.g. "rigid rigid free"; "" for FBP."""
    return " ".join(str(r.model["motion"]) for r in records if not r.failed and "motion" in r.model)


def extrapolated_time(records: Sequence[Record], short: Sequence[Record], steps: int | None) -> float:
    """Median over seeds of `extrapolate_time` of each successful run, paired by seed with the ``short`` run."""
    if not steps:
        return math.nan
    by_seed = {r.job.seed: r.stages for r in short if not r.failed}
    times = [extrapolate_time(r.run_time_s, r.stages, steps, by_seed.get(r.job.seed)) for r in records if not r.failed]
    return float(np.nanmedian(times)) if times and not np.isnan(times).all() else math.nan


def headline(rows: Sequence[dict], scene: str = HEADLINE_SCENE, target: float = HEADLINE_DICE) -> dict:
    """Time to median Dice >= ``target`` on ``scene``: ours (the default, else our fastest configuration
    that gets there) against the paper-sized model (its fastest measured run that gets there, else its
    time extrapolated to the paper's steps, assuming that schedule gets there); ``ratio`` = paper / ours."""
    mine = [r for r in rows if r["scene"] == scene and r["method"] == "nct"]
    reaching = [r for r in mine if r["dice_median"] >= target]
    ours = [r for r in reaching if not r["reference"]]
    best = (next((r for r in ours if r["config"] == "nct-default"), None)
            or min(ours, key=lambda r: r["run_time_s"], default=None))
    measured = min((r for r in reaching if r["reference"]), key=lambda r: r["run_time_s"], default=None)
    extrapolated = next((r for r in mine if r["reference"] and math.isfinite(r["time_extrapolated_s"])), None)
    out = {"scene": scene, "target_dice": target, "ours_config": best["config"] if best else None,
           "ours_time_s": best["run_time_s"] if best else math.nan, "paper_config": None,
           "paper_time_s": math.nan, "paper_basis": "not run or no time per stage reported"}
    if measured is not None:
        out.update(paper_config=measured["config"], paper_time_s=measured["run_time_s"], paper_basis="measured")
    elif extrapolated is not None:
        out.update(paper_config=extrapolated["config"], paper_time_s=extrapolated["time_extrapolated_s"],
                   paper_basis=f"extrapolated to {PAPER_STEPS} steps per stage; its short run reached Dice "
                               f"{extrapolated['dice_median']:.3f}, the extrapolation assumes the paper's "
                               f"schedule reaches {target}")
    out["ratio"] = out["paper_time_s"] / out["ours_time_s"]
    return out


def plot_accuracy_vs_time(rows: Sequence[dict], path: Path) -> Path:
    """Median Dice (bars: min-max over seeds) against median run time, per scene; Pareto front dashed;
    the paper-sized reference also at its extrapolated time (hollow marker)."""
    scenes = list(dict.fromkeys(r["scene"] for r in rows))
    names = list(dict.fromkeys(r["config"] for r in rows))
    colours = {n: plt.get_cmap("tab10")(i % 10) for i, n in enumerate(names)}
    ncols = min(3, len(scenes))
    nrows = math.ceil(len(scenes) / ncols)
    fig, axes = plt.subplots(nrows, ncols, figsize=(max(7.0, 4.6 * ncols), 3.8 * nrows + 1.0), squeeze=False,
                             layout="constrained")
    for ax, scene in zip(axes.flat, scenes):
        mine = [r for r in rows if r["scene"] == scene]
        for r in mine:
            y, t = r["dice_median"], r["run_time_s"]
            ax.errorbar([t], [y], yerr=[[y - r["dice_min"]], [r["dice_max"] - y]], fmt="o", capsize=3,
                        color=colours[r["config"]], label=r["config"])
            if math.isfinite(r["time_extrapolated_s"]):
                ax.plot([t, r["time_extrapolated_s"]], [y, y], ":", color=colours[r["config"]])
                ax.plot([r["time_extrapolated_s"]], [y], "o", mfc="none", color=colours[r["config"]],
                        label=f"{r['config']} at {PAPER_STEPS} steps (extrapolated)")
                ax.annotate("extrapolated", (r["time_extrapolated_s"], y), textcoords="offset points",
                            xytext=(-30, 8), fontsize=7)
        front = sorted((r for r in mine if r.get("pareto")), key=lambda r: r["run_time_s"])
        ax.step([r["run_time_s"] for r in front], [r["dice_median"] for r in front], "--", where="post",
                color="k", lw=0.8, label="Pareto front")
        ax.axhline(DICE_GOOD, color="grey", lw=0.5)
        ax.set(title=scene, xscale="log", xlabel="run time [s]", ylabel="median Dice", ylim=(0, 1.02))
    for ax in list(axes.flat)[len(scenes):]:
        ax.axis("off")
    handles, labels = _unique_legend(axes.flat)
    fig.legend(handles, labels, loc="outside lower center", ncol=2 * ncols, fontsize=8, frameon=False)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def _unique_legend(axes) -> tuple[list, list[str]]:
    seen: dict[str, object] = {}
    for ax in axes:
        for handle, label in zip(*ax.get_legend_handles_labels()):
            seen.setdefault(label, handle)
    return list(seen.values()), list(seen)


def plot_params_vs_accuracy(rows: Sequence[dict], path: Path) -> Path:
    """Median Dice against parameter count of each NeuralCT configuration: colour per scene, marker per config."""
    fig, ax = plt.subplots(figsize=(6.4, 4.2))
    shown = [r for r in rows if r["method"] == "nct" and math.isfinite(r["n_params"]) and r["n_params"] > 0]
    colours = {s: f"C{i}" for i, s in enumerate(dict.fromkeys(r["scene"] for r in rows))}
    markers = {c: "osD^v<>p*h"[i % 10] for i, c in enumerate(dict.fromkeys(r["config"] for r in shown))}
    for r in shown:
        ax.plot([r["n_params"]], [r["dice_median"]], markers[r["config"]], color=colours[r["scene"]], alpha=0.8)
    for scene, colour in colours.items():
        ax.plot([], [], "s", color=colour, label=scene)
    for config, marker in markers.items():
        ax.plot([], [], marker, color="k", mfc="none", label=config)
    if not shown:
        ax.text(0.5, 0.5, "no parameter counts reported\n(metrics.json model.n_params)", ha="center",
                transform=ax.transAxes)
    else:
        ax.set_xscale("log")
    ax.axhline(DICE_GOOD, color="grey", lw=0.5)
    ax.set(xlabel="parameters", ylabel="median Dice over seeds", ylim=(0, 1.02),
           title="NeuralCT: parameters against accuracy")
    ax.legend(fontsize=7, ncol=2)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def pivot(rows: Sequence[dict]) -> str:
    """One line per scene, one column per configuration: median Dice, median run time and, where the run
    chose its motion rung, the choice; the compact view of what each configuration costs and wins."""
    names = list(dict.fromkeys(r["config"] for r in rows))
    cells = {(r["scene"], r["config"]): r for r in rows}

    def cell(r: dict | None) -> str:
        if r is None:
            return "–"
        chosen = f", {r['rungs']}" if r["rungs"] and r["config"].endswith("auto") else ""
        return f"{r['dice_median']:.3f} ({fmt(r['run_time_s'])} s{chosen})"

    return markdown_table(["scene", *names], [[scene, *(cell(cells.get((scene, n))) for n in names)]
                                              for scene in dict.fromkeys(r["scene"] for r in rows)])


def report(rows: Sequence[dict], head: dict, command: str, elapsed_s: float) -> str:
    """The markdown note: headline, then one table row per scene and configuration."""
    table = markdown_table(
        ["scene", "config", "ok/runs", "Dice median [min–max]", "MSE median", "run time s", "process s",
         "peak MiB", "params", "motion", "Pareto"],
        [[r["scene"], r["config"], f"{r['runs'] - r['failed']}/{r['runs']}",
          f"{r['dice_median']:.3f} [{r['dice_min']:.3f}–{r['dice_max']:.3f}]", r["mse_median"],
          r["run_time_s"] if not math.isfinite(r["time_extrapolated_s"])
          else f"{r['run_time_s']:.3g} (extrapolated {r['time_extrapolated_s']:.0f})",
          r["wall_time_s"], r["peak_mem_mib"], "–" if math.isnan(r["n_params"]) else f"{r['n_params']:.0f}",
          r["rungs"] or "–", "yes" if r["pareto"] else ""] for r in rows])
    ratio = (f"**{head['ratio']:.1f}×**" if math.isfinite(head["ratio"]) else "not available")
    return "\n".join([
        "# Speed against accuracy", "", f"Command: `{command}` (this call: {elapsed_s / 60:.1f} min).", "",
        f"Headline ({head['scene']}, median Dice ≥ {head['target_dice']}): ours `{head['ours_config']}` "
        f"{fmt(head['ours_time_s'])} s; paper-sized `{head['paper_config']}` {fmt(head['paper_time_s'])} s "
        f"({head['paper_basis']}); ratio paper / ours {ratio}.", "",
        "Dice: median over seeds of each run's median over frames; a failed or diverged run counts as 0. "
        "Run time: data to metrics inside the run; process: the whole `nct` process. Params: "
        "`model.n_params` of metrics.json (– when not reported; FBP has none). Motion: the "
        "motion rung each seed's run chose (`motion=auto` chooses it from held-out views).", "",
        "Per scene: median Dice (median run time; for `motion=auto`, the rung chosen).", "", pivot(rows), "",
        "Per scene and configuration:", "", table, ""])


def run_benchmark(out: Path, scenes: dict[str, Sequence[str]], cfgs: Sequence[Config], seeds: Sequence[int],
                  n_jobs: int = 1, resume: bool = False, extra: Sequence[str] = (), command: str = "",
                  timeout_s: float | None = None, threads: int = 1) -> list[dict]:
    """Run every job, then write the outputs (`write_outputs`); returns the summary rows."""
    start = time.perf_counter()
    records = run_jobs(plan(out, scenes, cfgs, seeds, extra), n_jobs, resume, timeout_s, threads)
    return write_outputs(out, records, cfgs, command, time.perf_counter() - start)


def write_outputs(out: Path, records: Sequence[Record], cfgs: Sequence[Config], command: str,
                  elapsed_s: float) -> list[dict]:
    """runs.csv, summary.csv, the two charts and speed_accuracy.md into ``out``; returns the summary rows."""
    rows = summarise(records, cfgs)
    write_csv([r.row() for r in records], out / "runs.csv")
    write_csv(rows, out / "summary.csv")
    plot_accuracy_vs_time(rows, out / "accuracy_vs_time.png")
    plot_params_vs_accuracy(rows, out / "params_vs_accuracy.png")
    head = headline(rows)
    (out / "speed_accuracy.md").write_text(report(rows, head, command, elapsed_s))
    return rows


def main(argv: Sequence[str] | None = None) -> None:
    parser = benchmark_parser("speed_accuracy", __doc__.split("\n\n")[0],
                              "circle at 100 degrees, reduced steps, 2 seeds", "default: 0 1 2 (quick: 0 1)")
    parser.add_argument("--scenes", nargs="+", choices=list(SCENES), help="subset of the scenes")
    parser.add_argument("--configs", nargs="+", help="subset of the configurations, by name (e.g. fbp nct-default)")
    parser.add_argument("--paper-steps", type=positive_int,
                        help="steps per stage of the paper-sized run (default 100, quick 10)")
    args = parser.parse_args(argv)
    seeds = args.seeds or ([0, 1] if args.quick else [0, 1, 2])
    names = args.scenes or (QUICK_SCENES if args.quick else list(SCENES))
    paper_steps = args.paper_steps or (10 if args.quick else 100)
    cfgs = configs(default_config(), args.quick, paper_steps)
    if args.configs:
        unknown = set(args.configs) - {c.name for c in cfgs}
        if unknown:
            parser.error(f"--configs: unknown {sorted(unknown)}; choose from {[c.name for c in cfgs]}")
        cfgs = [c for c in cfgs if c.name in args.configs]
    command = "python benchmarks/speed_accuracy.py " + " ".join(sys.argv[1:] if argv is None else argv)
    rows = run_benchmark(args.out, {n: SCENES[n] for n in names}, cfgs, seeds, args.jobs, args.resume,
                         command=command.strip(), timeout_s=args.timeout, threads=args.threads)
    print((args.out / "speed_accuracy.md").read_text())
    print(f"{len(rows)} rows; outputs in {args.out}")


if __name__ == "__main__":
    main()
