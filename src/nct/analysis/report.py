"""``nct-report DIR``: one table, a few plots and a markdown summary of a Hydra multirun folder.

The jobs come from `nct.analysis.jobs`, the plots from `nct.analysis.report_figures`, the truth-free
choice from `nct.analysis.truth_free`; the command itself is `nct.cli.report`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from nct.analysis.jobs import (
    DISPLACEMENT,
    F_MAX,
    Job,
    collect_jobs,
    load_yaml,
    override_label,
    resume_command,
    short_value,
    union_keys,
    varying_keys,
)
from nct.analysis.report_figures import (
    METHODS,
    SUMMARY_STATS,
    Aggregate,
    aggregate,
    distinct,
    spread,
    tv_grid,
    write_plots,
)
from nct.analysis.truth_free import truth_free_lines
from nct.run.outcome import FINISHED
from nct.run.phases import breakdown
from nct.run.tables import fmt, markdown_table, write_csv

#: Flattened metrics.json keys of a phase's wall seconds (``phases.wall_s.<phase>``) and a stage's
#: (``stages.<stage>.wall_time_s``).
PHASE_KEY, STAGE_WALL = "phases.wall_s.", ".wall_time_s"
#: The per-job summaries of the summary's job table: those plotted, then the relative errors.
JOB_STATS = (*SUMMARY_STATS, ("median_psnr", "PSNR dB"), ("median_ssim", "SSIM"))


@dataclass(frozen=True)
class Report:
    """What `write_report` wrote: the table, the summary and the plots (only those that apply)."""

    jobs: list[Job]
    csv: Path
    summary: Path
    plots: dict[str, Path]


# ---------------------------------------------------------------- table


def table_columns(jobs: Sequence[Job]) -> list[str]:
    """CSV columns: job, each override key, status, error, wall time, each metric (first-seen order)."""
    overrides = union_keys(j.overrides for j in jobs)
    metrics = [k for k in union_keys(j.metrics for j in jobs) if k != "wall_time_s"]
    return ["job", *overrides, "status", "error", "wall_time_s", *metrics]


def write_table(jobs: Sequence[Job], path: Path) -> Path:
    """``report.csv``: one row per job (`table_columns`); cells a job lacks are empty."""
    rows = [{**job.overrides, **job.metrics, "job": job.num, "status": job.status, "error": job.error,
             "wall_time_s": job.wall_time_s} for job in jobs]
    return write_csv(rows, path, table_columns(jobs))


# ---------------------------------------------------------------- summary


def _by_setting_section(jobs: Sequence[Job], key: str, title: str) -> list[str]:
    stats = [(m, s, f"{m.upper()} {name}") for s, name in SUMMARY_STATS for m in METHODS]
    aggs = [aggregate(jobs, key, f"{m}.{s}") for m, s, _ in stats]
    header = [key, "jobs ok", *(title for _, _, title in stats)]
    rows = [[f"{x:g}", str(aggs[0].n[i]),
             *(_mean_sd(a, i) for a in aggs)] for i, x in enumerate(aggs[0].x)]
    return [f"## {title} (each job's median; {spread(aggs[0].n)})", "", markdown_table(header, rows), ""]


def _mean_sd(agg: Aggregate, i: int) -> str:
    """The mean, with ``± sd`` where there is a spread (two jobs or more)."""
    spread_known = np.isfinite(agg.mean[i]) and np.isfinite(agg.sd[i])
    return fmt(agg.mean[i]) + (f" ± {fmt(agg.sd[i], 2)}" if spread_known else "")


def _tv_table(jobs: Sequence[Job]) -> str:
    spaces, times, grid, _ = tv_grid(jobs)
    rows = [[f"{s:g}", *(fmt(v, 2) for v in grid[i])] for i, s in enumerate(spaces)]
    return markdown_table(["tv_space \\ tv_time", *(f"{t:g}" for t in times)], rows)


def job_phases(job: Job) -> dict[str, float]:
    """A job's wall seconds per phase (metrics.json ``phases``), the tournament split into its stages'
    fits and selection (`nct.run.phases.breakdown`); empty for a job that recorded none."""
    wall = {k.removeprefix(PHASE_KEY): float(v) for k, v in job.metrics.items() if k.startswith(PHASE_KEY)}
    stages = {k.removeprefix("stages.").removesuffix(STAGE_WALL): float(v) for k, v in job.metrics.items()
              if k.startswith("stages.") and k.endswith(STAGE_WALL)}
    return breakdown(wall, stages)


def _phases_section(jobs: Sequence[Job], varying: Sequence[str]) -> list[str]:
    """Where each job's time went, a column per phase; none when no job recorded its phases."""
    timed = [(j, job_phases(j)) for j in jobs]
    timed = [(j, phases) for j, phases in timed if phases]
    if not timed:
        return []
    names = union_keys(phases for _, phases in timed)
    header = ["job", *varying, *names, "wall s"]
    rows = [[str(j.num), *(short_value(j.overrides.get(k, "")) for k in varying), *(phases.get(n) for n in names),
             j.wall_time_s] for j, phases in timed]
    return ["## Where the time went (wall s per phase, metrics.json `phases`; fits: the tournament's stages, "
            "selection: the rest of it)", "", markdown_table(header, rows), ""]


def _first_line(error: str | None) -> str:
    lines = (error or "").strip().splitlines()
    return lines[0] if lines else "no error recorded"


def summary_lines(sweep_dir: Path, jobs: Sequence[Job], plots: dict[str, Path]) -> list[str]:
    """The markdown summary: counts, tables by swept setting, every job, what did not finish, the
    runs' warnings (status.json: suspect fits, motion the data do not determine)."""
    counts: dict[str, int] = {}
    for job in jobs:
        counts[job.status] = counts.get(job.status, 0) + 1
    lines = [f"# Sweep report: `{sweep_dir.resolve()}`", "",
             f"{len(jobs)} jobs: " + ", ".join(f"{n} {s}" for s, n in sorted(counts.items())) + ".", ""]
    varying = varying_keys(jobs)
    lines += truth_free_lines(jobs, varying)
    for key, title in ((DISPLACEMENT, "By displacement"), (F_MAX, "By F_max")):
        if len(distinct(jobs, key)) > 1:
            lines += _by_setting_section(jobs, key, title)
    if "tv_grid" in plots:
        counts = tv_grid(jobs)[3]
        lines += [f"## NCT median Dice on the TV grid ({spread(counts.ravel(), 'mean')}; rows: TV space, "
                  "columns: TV time)", "", _tv_table(jobs), ""]
    header = ["job", *varying, "status", *(f"{m.upper()} {name}" for _, name in JOB_STATS for m in METHODS),
              "held-out loss", "rung chosen", "wall s"]
    rows = [[str(j.num), *(short_value(j.overrides.get(k, "")) for k in varying), j.status,
             *(j.metric(f"{m}.{s}") for s, _ in JOB_STATS for m in METHODS),
             fmt(j.metric("heldout_loss"), 4), str(j.metrics.get("selection.rung", "")), j.wall_time_s] for j in jobs]
    lines += ["## Jobs", "", markdown_table(header, rows), ""]
    lines += _phases_section(jobs, varying)
    broken = [j for j in jobs if j.status != FINISHED or j.error]
    lines += ["## Failed, diverged, unfinished or missing", ""]
    lines += [f"- job {j.num} ({override_label(j, varying) or 'no varying override'}): **{j.status}**: "
              f"{_first_line(j.error)}" for j in broken] or ["None."]
    multirun = load_yaml(sweep_dir / "multirun.yaml")
    command = resume_command(multirun, sweep_dir.resolve()) if broken and multirun is not None else None
    if command:
        lines += ["", "Run the jobs that are not ok again, leaving finished ones untouched "
                  "(stop any run still going first):", "", f"    {command}"]
    lines += ["", "## Warnings", ""]
    lines += [f"- job {j.num} ({override_label(j, varying) or 'no varying override'}): {w}"
              for j in jobs for w in j.warnings] or ["None: no run warned."]
    lines += ["", "## Plots", "", *(f"![{name}]({path.name})" for name, path in plots.items()), ""]
    return lines


# ---------------------------------------------------------------- entry points


def write_report(sweep_dir: Path, out_dir: Path | None = None) -> Report:
    """Read the multirun in ``sweep_dir``; write report.csv, summary.md and plots to ``out_dir``.

    ``out_dir`` defaults to ``sweep_dir/report``.
    """
    sweep_dir = Path(sweep_dir)
    jobs = collect_jobs(sweep_dir)
    out_dir = Path(out_dir) if out_dir is not None else sweep_dir / "report"
    out_dir.mkdir(parents=True, exist_ok=True)
    table = write_table(jobs, out_dir / "report.csv")
    plots = write_plots(jobs, out_dir)
    summary = out_dir / "summary.md"
    summary.write_text("\n".join(summary_lines(sweep_dir, jobs, plots)))
    return Report(jobs, table, summary, plots)

