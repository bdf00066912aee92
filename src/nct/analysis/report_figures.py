"""The plots of a sweep report: Dice and MSE against a swept setting, the TV-weight grid, accuracy
against wall time, held-out loss against Dice; each built as a Figure (titled, axes labelled with
units, legends outside the axes so they cover no point), then written as a PNG.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from nct.analysis.jobs import DISPLACEMENT, F_MAX, TV_SPACE, TV_TIME, Job, finished
from nct.run.outcome import FINISHED

METHODS = ("fbp", "nct")
SUMMARY_STATS = (("median_dice", "Dice"), ("median_mse", "MSE"))  # per-job summaries the plots show
AXIS_LABELS = {"median_dice": "median Dice of a job", "median_mse": "median MSE of a job (intensity unit²)"}


@dataclass(frozen=True)
class Aggregate:
    """Mean and sample sd (over the finished jobs at each x, e.g. seeds) of one metric: arrays [X];
    sd is NaN where fewer than two jobs finished (one job has no spread)."""

    x: np.ndarray
    n: np.ndarray
    mean: np.ndarray
    sd: np.ndarray


def distinct(jobs: Sequence[Job], key: str) -> list[float]:
    """Sorted distinct values of a plotted setting over the finished jobs."""
    return sorted({j.settings[key] for j in finished(jobs) if key in j.settings})


def aggregate(jobs: Sequence[Job], key: str, metric: str) -> Aggregate:
    """``metric`` (e.g. ``nct.median_dice``) of the finished jobs grouped by setting ``key``."""
    xs = distinct(jobs, key)
    groups = [np.array([j.metric(metric) for j in finished(jobs) if j.settings.get(key) == x]) for x in xs]
    groups = [g[np.isfinite(g)] for g in groups]
    mean = np.array([g.mean() if g.size else np.nan for g in groups])
    sd = np.array([g.std(ddof=1) if g.size > 1 else np.nan for g in groups])
    return Aggregate(np.array(xs), np.array([g.size for g in groups]), mean, sd)


def spread(n: np.ndarray, stat: str = "mean ± sd") -> str:
    """What a value shown per setting is, given the number of jobs ``n`` behind each: one job's value,
    or ``stat`` over several (settings with no job left out)."""
    n = n[n > 0]
    if n.size == 0 or n.max() == 1:
        return "one job per setting"
    jobs = f"{n.min()}" if n.min() == n.max() else f"{n.min()}-{n.max()}"
    return f"{stat} over {jobs} jobs per setting"


def log_scale_fits(values: Sequence[float]) -> bool:
    """A log axis suits ``values`` when they are positive and span two decades or more: it then labels
    only whole decades. Over a narrower range it labels values between decades (3×10⁻³, 4×10⁻³...), long
    labels that overlap; a linear axis with one shared exponent reads better there."""
    finite = np.asarray([v for v in values if math.isfinite(v)])
    return finite.size > 1 and finite.min() > 0 and finite.max() / finite.min() >= 100


def _legend_outside(fig: Figure, title: str | None = None) -> None:
    """One legend for every labelled curve of ``fig``, in a row below the panels (so it covers none)."""
    entries = {label: handle for ax in fig.axes for handle, label in zip(*ax.get_legend_handles_labels())}
    if entries:
        fig.legend(entries.values(), entries.keys(), loc="outside lower center", ncols=len(entries), title=title,
                   fontsize=9, title_fontsize=9)


def metrics_vs_figure(jobs: Sequence[Job], key: str, label: str) -> Figure:
    """Median Dice and median MSE per job against ``key``, FBP and NCT; several jobs at one setting
    (e.g. seeds): their mean ± sd, as the legend says."""
    fig = Figure(figsize=(11, 4), layout="constrained")
    counts = []
    for ax, (stat, name) in zip(fig.subplots(1, 2), SUMMARY_STATS):
        aggs = {method: aggregate(jobs, key, f"{method}.{stat}") for method in METHODS}
        aggs = {method: agg for method, agg in aggs.items() if np.isfinite(agg.mean).any()}
        for method, agg in aggs.items():
            yerr = agg.sd if np.isfinite(agg.sd).any() else None
            ax.errorbar(agg.x, agg.mean, yerr=yerr, marker="o", capsize=3, label=method.upper())
        if stat == "median_mse" and log_scale_fits([v for agg in aggs.values() for v in agg.mean]):
            ax.set_yscale("log")
        ax.set_xlabel(label)
        ax.set_ylabel(AXIS_LABELS[stat])
        ax.grid(alpha=0.3)
        counts += [agg.n for agg in aggs.values()]
    _legend_outside(fig, spread(np.concatenate(counts)) if counts else None)
    fig.suptitle(f"Median Dice and MSE of each job against {label}")
    return fig


def tv_grid(jobs: Sequence[Job], metric: str = "nct.median_dice"
            ) -> tuple[list[float], list[float], np.ndarray, np.ndarray]:
    """Mean ``metric`` on the TV-space x TV-time grid: (space values, time values, mean [S,T] (NaN: no
    job), number of jobs averaged [S,T])."""
    spaces, times = distinct(jobs, TV_SPACE), distinct(jobs, TV_TIME)
    grid = np.full((len(spaces), len(times)), np.nan)
    counts = np.zeros((len(spaces), len(times)), dtype=int)
    for i, s in enumerate(spaces):
        for k, t in enumerate(times):
            values = [j.metric(metric) for j in finished(jobs)
                      if j.settings.get(TV_SPACE) == s and j.settings.get(TV_TIME) == t]
            values = [v for v in values if math.isfinite(v)]
            if values:
                grid[i, k], counts[i, k] = float(np.mean(values)), len(values)
    return spaces, times, grid, counts


def tv_grid_figure(jobs: Sequence[Job]) -> Figure:
    """Heat map of NCT median Dice over TV-space (rows) x TV-time (columns) weights (paper Fig. 3 top)."""
    spaces, times, grid, counts = tv_grid(jobs)
    fig = Figure(figsize=(max(4.5, 2.0 + 0.6 * len(times)), max(3.5, 1.5 + 0.45 * len(spaces))),
                 layout="constrained")
    ax = fig.subplots()
    image = ax.imshow(grid, origin="lower", cmap="viridis", vmin=0.0, vmax=1.0, aspect="auto")
    ax.set_xticks(range(len(times)), [f"{t:g}" for t in times])
    ax.set_yticks(range(len(spaces)), [f"{s:g}" for s in spaces])
    ax.set_xlabel("loss.tv_time (TV in time)")
    ax.set_ylabel("loss.tv_space (TV in space)")
    for (i, k), value in np.ndenumerate(grid):
        if np.isfinite(value):
            ax.text(k, i, f"{value:.2f}", ha="center", va="center", fontsize=7,
                    color="black" if value > 0.6 else "white")
    fig.colorbar(image, ax=ax, label="NCT median Dice")
    ax.set_title(f"NCT median Dice: {spread(counts.ravel(), 'mean')}", fontsize=9)
    return fig


def accuracy_vs_time_figure(jobs: Sequence[Job]) -> Figure:
    """NCT median Dice against the job's wall time, labelled by job number; failed ones as crosses at 0."""
    fig = Figure(figsize=(6, 4), layout="constrained")
    ax = fig.subplots()
    done = finished(jobs)
    ax.scatter([j.wall_time_s for j in done], [j.metric("nct.median_dice") for j in done],
               label="NCT, labelled by job number")
    for job in done:
        ax.annotate(str(job.num), (job.wall_time_s, job.metric("nct.median_dice")), xytext=(3, 3),
                    textcoords="offset points", fontsize=7)
    broken = [j for j in jobs if j.status != FINISHED and j.wall_time_s is not None]
    if broken:
        ax.scatter([j.wall_time_s for j in broken], [0.0] * len(broken), marker="x", color="red",
                   label="failed / diverged (no Dice)")
    ax.set_xlabel("wall time per job (s)")
    ax.set_ylabel("NCT median Dice")
    ax.grid(alpha=0.3)
    _legend_outside(fig)
    fig.suptitle("Accuracy against wall time")
    return fig


def heldout_vs_dice_figure(jobs: Sequence[Job]) -> Figure:
    """NCT median Dice against the truth-free held-out sinogram loss: is the search score a fair proxy?"""
    fig = Figure(figsize=(6, 4), layout="constrained")
    ax = fig.subplots()
    done = finished(jobs)
    losses = [j.metric("heldout_loss") for j in done]
    ax.scatter(losses, [j.metric("nct.median_dice") for j in done], label="NCT, one finished job each")
    if log_scale_fits(losses):
        ax.set_xscale("log")
    ax.set_xlabel("held-out sinogram loss (relative L1, unitless; truth-free, lower is better)")
    ax.set_ylabel("NCT median Dice")
    ax.grid(alpha=0.3)
    _legend_outside(fig)
    fig.suptitle("Is the truth-free score a fair proxy for Dice?")
    return fig


def figures(jobs: Sequence[Job]) -> dict[str, Figure]:
    """Every plot whose setting varies over the finished jobs (accuracy vs wall time always), by name."""
    plots: dict[str, Figure] = {}
    if len(distinct(jobs, DISPLACEMENT)) > 1:
        plots["displacement"] = metrics_vs_figure(jobs, DISPLACEMENT, "displacement per rotation (deg)")
    if len(distinct(jobs, TV_SPACE)) > 1 and len(distinct(jobs, TV_TIME)) > 1:
        plots["tv_grid"] = tv_grid_figure(jobs)
    if len(distinct(jobs, F_MAX)) > 1:
        plots["f_max"] = metrics_vs_figure(jobs, F_MAX, "model.f_max, F_max (cycles/rotation)")
    plots["accuracy_vs_time"] = accuracy_vs_time_figure(jobs)
    if sum(math.isfinite(j.metric("heldout_loss")) and j.metric("heldout_loss") > 0 for j in finished(jobs)) > 1:
        plots["heldout_vs_dice"] = heldout_vs_dice_figure(jobs)
    return plots


def write_plots(jobs: Sequence[Job], out_dir: Path) -> dict[str, Path]:
    """`figures` as ``out_dir/<name>.png``."""
    paths: dict[str, Path] = {}
    for name, fig in figures(jobs).items():
        paths[name] = out_dir / f"{name}.png"
        fig.savefig(paths[name], dpi=120)
    return paths

