"""``nct-report DIR``: one table, a few plots and a markdown summary of a Hydra multirun folder.

Reads every job folder under DIR (``.hydra/``, ``status.json``, ``metrics.json``, see
docs/ARCHITECTURE.md) and, from ``multirun.yaml``, the jobs that were planned but never started.
A failed, diverged, unfinished or missing job is a row like any other, with its error: never dropped.
"""

from __future__ import annotations

import argparse
import math
import shlex
import sys
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure
from omegaconf import DictConfig, OmegaConf

from nct.run.outcome import FINISHED, read_outcome
from nct.run.tables import fmt, markdown_table, write_csv

#: Config keys the plots know.
DISPLACEMENT, TV_SPACE, TV_TIME, F_MAX = "phantom.displacement_deg", "loss.tv_space", "loss.tv_time", "model.f_max"
PLOTTED_KEYS = (DISPLACEMENT, TV_SPACE, TV_TIME, F_MAX)
METHODS = ("fbp", "nct")
#: The settings that order a model's freedom, and which way is simpler: a lower F_max, higher TV weights.
SIMPLER = ((F_MAX, 1.0), (TV_TIME, -1.0), (TV_SPACE, -1.0))
SUMMARY_STATS = (("median_dice", "Dice"), ("median_mse", "MSE"))  # per-job summaries the plots show


class ReportError(ValueError):
    """DIR is not a multirun folder this report can read."""


@dataclass
class Job:
    """One job of a sweep: found on disk, or only planned in ``multirun.yaml`` (status ``missing``).

    ``metrics`` are the scalars of ``metrics.json`` flattened to dotted keys (``nct.median_dice``);
    ``settings`` the values of `PLOTTED_KEYS` from the job's config, overridden by its overrides.
    """

    num: int | None
    overrides: dict[str, str]
    status: str
    error: str | None = None
    wall_time_s: float | None = None
    metrics: dict[str, float | str] = field(default_factory=dict)
    settings: dict[str, float] = field(default_factory=dict)
    path: Path | None = None
    warnings: tuple[str, ...] = ()

    def metric(self, name: str) -> float:
        """A numeric metric, NaN when the job has none."""
        value = self.metrics.get(name)
        return float(value) if isinstance(value, (int, float)) else math.nan


@dataclass(frozen=True)
class Report:
    """What `write_report` wrote: the table, the summary and the plots (only those that apply)."""

    jobs: list[Job]
    csv: Path
    summary: Path
    plots: dict[str, Path]


# ---------------------------------------------------------------- reading


def find_job_dirs(sweep_dir: Path) -> list[Path]:
    """Every folder below ``sweep_dir`` that Hydra ran a job in (it holds ``.hydra/hydra.yaml``)."""
    return sorted(p.parent.parent for p in sweep_dir.glob("**/.hydra/hydra.yaml")
                  if p.parent.parent != sweep_dir and not _hidden(p.parent.parent, sweep_dir))


def _hidden(path: Path, root: Path) -> bool:
    return any(part.startswith(".") for part in path.relative_to(root).parts)


def collect_jobs(sweep_dir: Path) -> list[Job]:
    """All jobs of the multirun in ``sweep_dir``, found and missing, ordered by job number."""
    sweep_dir = Path(sweep_dir)
    if not sweep_dir.is_dir():
        raise ReportError(f"{sweep_dir} does not exist or is not a folder")
    if (sweep_dir / ".hydra").is_dir():
        raise ReportError(f"{sweep_dir} is a single run, not a multirun folder (run `nct -m ...`)")
    dirs = find_job_dirs(sweep_dir)
    plan = _load_yaml(sweep_dir / "multirun.yaml")
    if plan is None:  # the Optuna sweeper writes none: then DIR's subfolders must be its jobs
        dirs = [d for d in dirs if d.parent == sweep_dir]
        plans = [_load_yaml(d / ".hydra" / "hydra.yaml") for d in dirs]
        if not plans or any(OmegaConf.select(p, "hydra.mode", default=None) != "MULTIRUN" for p in plans):
            raise ReportError(f"{sweep_dir} is not a multirun folder: no multirun.yaml, and its subfolders "
                              "are not the jobs of one multirun")
        plan = plans[0]
    jobs = [read_job(d) for d in dirs]
    jobs += missing_jobs(plan, {j.num for j in jobs})
    return sorted(jobs, key=lambda j: (j.num is None, j.num if j.num is not None else 0, str(j.path)))


def read_job(job_dir: Path) -> Job:
    """One job folder: overrides, its `read_outcome` (status, error, wall time, warnings) and flattened metrics."""
    hydra_dir = job_dir / ".hydra"
    overrides = _parse_overrides(_load_yaml_list(hydra_dir / "overrides.yaml"))
    num = _job_num(hydra_dir / "hydra.yaml")
    outcome = read_outcome(job_dir)
    metrics = flatten_metrics(outcome.metrics) if outcome.metrics is not None else {}
    wall = outcome.wall_time_s
    if wall is None and outcome.metrics is not None:
        wall = _number(outcome.metrics.get("wall_time_s"))
    settings = _settings(_load_yaml(hydra_dir / "config.yaml"), overrides)
    return Job(num, overrides, outcome.status, outcome.error, wall, metrics, settings, job_dir, outcome.warnings)


def missing_jobs(plan: DictConfig, found: set[int | None]) -> list[Job]:
    """Jobs planned by the sweep whose folder does not exist (yet).

    ``plan``: ``multirun.yaml`` (or, without it, a job's ``hydra.yaml``). The basic sweeper's job list
    is rebuilt exactly (its cartesian product, in its order) from multirun.yaml; for the Optuna
    sweeper only the number of trials is known, so missing trials have no overrides.
    """
    sweeper = OmegaConf.select(plan, "hydra.sweeper", default=None) or {}
    planned: list[dict[str, str]] | None = None
    if str(sweeper.get("_target_", "")).endswith("BasicSweeper"):
        planned = planned_overrides(sweeper.get("params") or {},
                                    list(OmegaConf.select(plan, "hydra.overrides.task", default=[]) or []))
    elif isinstance(sweeper.get("n_trials"), int):
        planned = [{} for _ in range(sweeper["n_trials"])]
    if planned is None:
        return []
    return [Job(num, overrides, "missing", "planned in multirun.yaml but never started")
            for num, overrides in enumerate(planned) if num not in found]


def planned_overrides(params: dict | DictConfig, task_overrides: Sequence[str]) -> list[dict[str, str]]:
    """Each job's overrides, in job-number order, as Hydra's basic sweeper expands them."""
    from hydra._internal.core_plugins.basic_sweeper import BasicSweeper
    from hydra.core.override_parser.overrides_parser import OverridesParser

    args = [f"{k}={v}" for k, v in dict(params).items()] + list(task_overrides)
    parsed = OverridesParser.create().parse_overrides(args)
    return [_parse_overrides(job) for job in BasicSweeper.split_arguments(parsed, None)[0]]


def resume_command(multirun: DictConfig, sweep_dir: Path) -> str | None:
    """The command that finishes an interrupted sweep in place (basic sweeper only).

    Same overrides as the original command, the same sweep folder and ``resume=true``: job numbers
    map to the same overrides, finished jobs are skipped untouched, the others run again.
    """
    if not str(OmegaConf.select(multirun, "hydra.sweeper._target_", default="")).endswith("BasicSweeper"):
        return None
    dropped = ("hydra.sweep.dir=", "hydra.mode=", "resume=")
    overrides = [o for group in ("hydra", "task")
                 for o in OmegaConf.select(multirun, f"hydra.overrides.{group}", default=None) or []
                 if not str(o).startswith(dropped)]
    args = ["nct", "-m", *map(str, overrides), f"hydra.sweep.dir={sweep_dir}", "resume=true"]
    return " ".join(shlex.quote(a) for a in args)


def flatten_metrics(metrics: dict, prefix: str = "") -> dict[str, float | str]:
    """Scalars of a metrics.json as dotted keys; an IQR pair ``[q25, q75]`` gives ``_q25``/``_q75``.

    Other lists (per-frame values, frame times) are left out: they are not one number per job.
    """
    flat: dict[str, float | str] = {}
    for key, value in metrics.items():
        name = f"{prefix}{key}"
        if isinstance(value, dict):
            flat.update(flatten_metrics(value, f"{name}."))
        elif isinstance(value, list) and key.startswith("iqr_") and len(value) == 2:
            flat[f"{name}_q25"], flat[f"{name}_q75"] = (float(v) for v in value)
        elif isinstance(value, bool):
            flat[name] = float(value)
        elif isinstance(value, (int, float, str)):
            flat[name] = value
    return flat


def _settings(config: DictConfig | None, overrides: dict[str, str]) -> dict[str, float]:
    settings: dict[str, float] = {}
    for key in PLOTTED_KEYS:
        value = overrides.get(key)
        if value is None and config is not None:
            try:
                value = OmegaConf.select(config, key, default=None)
            except Exception:  # an interpolation that only resolves inside Hydra
                value = None
        number = _number(value)
        if number is not None:
            settings[key] = number
    return settings


def _parse_overrides(lines: Sequence[str]) -> dict[str, str]:
    """``["+a.b=1", "c=x"]`` -> ``{"a.b": "1", "c": "x"}`` (the key without ``+``/``++``/``~``)."""
    pairs = (line.lstrip("+~").partition("=") for line in lines)
    return {key: value for key, _, value in pairs}


def _job_num(hydra_yaml: Path) -> int | None:
    conf = _load_yaml(hydra_yaml)
    num = OmegaConf.select(conf, "hydra.job.num", default=None) if conf is not None else None
    return int(num) if isinstance(num, int) else None


def _load_yaml(path: Path) -> DictConfig | None:
    try:
        loaded = OmegaConf.load(path)
    except Exception:
        return None
    return loaded if isinstance(loaded, DictConfig) else None


def _load_yaml_list(path: Path) -> list[str]:
    try:
        loaded = OmegaConf.load(path)
    except Exception:
        return []
    return [str(x) for x in loaded] if not isinstance(loaded, DictConfig) else []


def _number(value: object) -> float | None:
    if isinstance(value, bool) or value is None:
        return None
    try:
        return float(value)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        return None


# ---------------------------------------------------------------- table


def table_columns(jobs: Sequence[Job]) -> list[str]:
    """CSV columns: job, each override key, status, error, wall time, each metric (first-seen order)."""
    overrides = _union(j.overrides for j in jobs)
    metrics = [k for k in _union(j.metrics for j in jobs) if k != "wall_time_s"]
    return ["job", *overrides, "status", "error", "wall_time_s", *metrics]


def _union(dicts: Iterable[dict]) -> list[str]:
    return list(dict.fromkeys(k for d in dicts for k in d))


def write_table(jobs: Sequence[Job], path: Path) -> Path:
    """``report.csv``: one row per job (`table_columns`); cells a job lacks are empty."""
    rows = [{**job.overrides, **job.metrics, "job": job.num, "status": job.status, "error": job.error,
             "wall_time_s": job.wall_time_s} for job in jobs]
    return write_csv(rows, path, table_columns(jobs))


# ---------------------------------------------------------------- aggregates and plots


@dataclass(frozen=True)
class Aggregate:
    """Mean and sample sd (over the finished jobs at each x, e.g. seeds) of one metric: arrays [X];
    sd is NaN where fewer than two jobs finished (one job has no spread)."""

    x: np.ndarray
    n: np.ndarray
    mean: np.ndarray
    sd: np.ndarray


def finished(jobs: Sequence[Job]) -> list[Job]:
    """The jobs that finished ok and have metrics: the only ones plotted and aggregated."""
    return [j for j in jobs if j.status == FINISHED and j.metrics]


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


def metrics_vs_figure(jobs: Sequence[Job], key: str, label: str) -> Figure:
    """Median Dice and median MSE per job against ``key``, FBP and NCT; several jobs at one setting
    (e.g. seeds): their mean ± sd, as the legend says."""
    fig = Figure(figsize=(10, 4), layout="constrained")
    for ax, (stat, name) in zip(fig.subplots(1, 2), SUMMARY_STATS):
        aggs = {method: aggregate(jobs, key, f"{method}.{stat}") for method in METHODS}
        aggs = {method: agg for method, agg in aggs.items() if np.isfinite(agg.mean).any()}
        for method, agg in aggs.items():
            yerr = agg.sd if np.isfinite(agg.sd).any() else None
            ax.errorbar(agg.x, agg.mean, yerr=yerr, marker="o", capsize=3, label=method.upper())
        if stat == "median_mse" and log_scale_fits([v for agg in aggs.values() for v in agg.mean]):
            ax.set_yscale("log")
        ax.set_xlabel(label)
        ax.set_ylabel(f"median {name} of a job")
        ax.grid(alpha=0.3)
        if aggs:
            ax.legend(title=spread(np.concatenate([agg.n for agg in aggs.values()])), fontsize=9, title_fontsize=9)
    fig.suptitle(f"Dice and MSE against {label}")
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
    ax.legend()
    return fig


def heldout_vs_dice_figure(jobs: Sequence[Job]) -> Figure:
    """NCT median Dice against the truth-free held-out sinogram loss: is the search score a fair proxy?"""
    fig = Figure(figsize=(6, 4), layout="constrained")
    ax = fig.subplots()
    done = finished(jobs)
    losses = [j.metric("heldout_loss") for j in done]
    ax.scatter(losses, [j.metric("nct.median_dice") for j in done])
    if log_scale_fits(losses):
        ax.set_xscale("log")
    ax.set_xlabel("held-out sinogram loss (truth-free; lower is better)")
    ax.set_ylabel("NCT median Dice")
    ax.grid(alpha=0.3)
    return fig


def figures(jobs: Sequence[Job]) -> dict[str, Figure]:
    """Every plot whose setting varies over the finished jobs (accuracy vs wall time always), by name."""
    plots: dict[str, Figure] = {}
    if len(distinct(jobs, DISPLACEMENT)) > 1:
        plots["displacement"] = metrics_vs_figure(jobs, DISPLACEMENT, "displacement per rotation (deg)")
    if len(distinct(jobs, TV_SPACE)) > 1 and len(distinct(jobs, TV_TIME)) > 1:
        plots["tv_grid"] = tv_grid_figure(jobs)
    if len(distinct(jobs, F_MAX)) > 1:
        plots["f_max"] = metrics_vs_figure(jobs, F_MAX, "model.f_max (F_max)")
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


def _first_line(error: str | None) -> str:
    lines = (error or "").strip().splitlines()
    return lines[0] if lines else "no error recorded"


SCENE_KEYS = ("data", "phantom", "scanner", "image", "experiment")  # what fixes the measured scene
REPLICATE_KEY = "seed"  # a seed redraws the noise and the fit's start: a replicate of the same setting


@dataclass(frozen=True)
class Setting:
    """The finished jobs of one setting on one scene, one per seed: the truth-free score's unit.
    Over two seeds or more its held-out loss is the mean and its standard error the spread over
    seeds (a run's own error, over its held-out views, misses how much the fit itself varies)."""

    jobs: tuple[Job, ...]

    def mean(self, name: str) -> float:
        return float(np.mean([j.metric(name) for j in self.jobs]))

    @property
    def se(self) -> float:
        """The standard error of the held-out loss (0 when unknown)."""
        if len(self.jobs) > 1:
            return float(np.std([j.metric("heldout_loss") for j in self.jobs], ddof=1) / math.sqrt(len(self.jobs)))
        se = self.jobs[0].metric("heldout_se")
        return se if math.isfinite(se) else 0.0

    def get(self, key: str) -> float:
        return self.jobs[0].settings.get(key, 0.0)


def scenes(jobs: Sequence[Job]) -> dict[tuple[tuple[str, str], ...], list[Setting]]:
    """Finished jobs with a held-out loss, by scene (``SCENE_KEYS`` overrides) and setting (the other
    overrides, seed aside), so that a truth-free score may choose among settings on the same data.
    A setting counts only with every seed that any setting of its scene finished (paired replicates)."""
    by: dict[tuple[tuple[str, str], ...], dict[tuple[tuple[str, str], ...], list[Job]]] = {}
    for job in finished(jobs):
        if math.isfinite(job.metric("heldout_loss")):
            items = sorted(job.overrides.items())
            scene = tuple((k, v) for k, v in items if k.split(".")[0] in SCENE_KEYS)
            setting = tuple((k, v) for k, v in items if k.split(".")[0] not in (*SCENE_KEYS, REPLICATE_KEY))
            by.setdefault(scene, {}).setdefault(setting, []).append(job)
    out = {}
    for scene, settings in by.items():
        seeds = {j.overrides.get(REPLICATE_KEY) for group in settings.values() for j in group}
        out[scene] = [Setting(tuple(g)) for g in settings.values() if {j.overrides.get(REPLICATE_KEY) for j in g} == seeds]
    return out


def truth_free_pick(settings: Sequence[Setting]) -> Setting:
    """The one-standard-error rule on settings of one scene: of the settings whose mean held-out
    loss is within one standard error (`Setting.se`, of the lowest) of the lowest, the simplest by
    the swept settings of ``SIMPLER``, then the lowest loss."""
    best = min(settings, key=lambda s: s.mean("heldout_loss"))
    bound = best.mean("heldout_loss") + best.se
    swept = [(key, sign) for key, sign in SIMPLER if len({s.get(key) for s in settings}) > 1]
    near = [s for s in settings if s.mean("heldout_loss") <= bound]
    return min(near, key=lambda s: (*(sign * s.get(key) for key, sign in swept), s.mean("heldout_loss")))


def truth_free_lines(jobs: Sequence[Job], varying: Sequence[str]) -> list[str]:
    """Per scene with two settings or more: the setting the truth-free score picks
    (``truth_free_pick``), and the Dice (mean over seeds) it gives up against the setting the truth
    would pick (the score is only comparable on the same data)."""
    lines = []
    for settings in scenes(jobs).values():
        if len(settings) < 2:
            continue
        pick = truth_free_pick(settings)
        top = max(settings, key=lambda s: s.mean("nct.median_dice"))
        lost = top.mean("nct.median_dice") - pick.mean("nct.median_dice")
        seeds = len(pick.jobs)
        lines.append(f"- {len(settings)} settings of one scene{f', {seeds} seeds each' if seeds > 1 else ''}: the "
                     f"truth-free score picks {_setting_label(pick, varying)}, NCT median Dice "
                     f"{fmt(pick.mean('nct.median_dice'))}; the best Dice is {_setting_label(top, varying)}'s "
                     f"{fmt(top.mean('nct.median_dice'))}: {fmt(lost)} lost.")
    if not lines:
        return ["Truth-free choice: none to make (no two settings ran on the same scene: the held-out loss "
                "compares settings on the same data only).", ""]
    return ["Truth-free choice (among settings of the same scene: the simplest, lowest F_max then highest TV "
            "weights, whose held-out sinogram loss is within one standard error of the lowest; over several "
            "seeds, the mean loss and Dice, and the error from the spread over seeds):", "", *lines, ""]


def _setting_label(setting: Setting, varying: Sequence[str]) -> str:
    """"job 3 (model.f_max=0.3)", or "jobs 1 5 9 (model.f_max=0.3)" for a setting over several seeds."""
    keys = [k for k in varying if k != REPLICATE_KEY]
    label = _label(setting.jobs[0], keys) or "no varying override"
    nums = " ".join(str(j.num) for j in setting.jobs)
    return f"job{'s' if len(setting.jobs) > 1 else ''} {nums} ({label})"


def _varying(jobs: Sequence[Job]) -> list[str]:
    keys = _union(j.overrides for j in jobs)
    return [k for k in keys if len({j.overrides.get(k) for j in jobs}) > 1]


def _label(job: Job, keys: Sequence[str]) -> str:
    return " ".join(f"{k}={_short(job.overrides[k])}" for k in keys if k in job.overrides)


def _short(value: str) -> str:
    """An override value for reading: numbers to 4 significant digits (Optuna's have 16)."""
    number = _number(value)
    return f"{number:.4g}" if number is not None and "." in value else value


def summary_lines(sweep_dir: Path, jobs: Sequence[Job], plots: dict[str, Path]) -> list[str]:
    """The markdown summary: counts, tables by swept setting, every job, what did not finish, the
    warnings of suspect fits."""
    counts: dict[str, int] = {}
    for job in jobs:
        counts[job.status] = counts.get(job.status, 0) + 1
    lines = [f"# Sweep report: `{sweep_dir.resolve()}`", "",
             f"{len(jobs)} jobs: " + ", ".join(f"{n} {s}" for s, n in sorted(counts.items())) + ".", ""]
    varying = _varying(jobs)
    lines += truth_free_lines(jobs, varying)
    for key, title in ((DISPLACEMENT, "By displacement"), (F_MAX, "By F_max")):
        if len(distinct(jobs, key)) > 1:
            lines += _by_setting_section(jobs, key, title)
    if "tv_grid" in plots:
        counts = tv_grid(jobs)[3]
        lines += [f"## NCT median Dice on the TV grid ({spread(counts.ravel(), 'mean')}; rows: TV space, "
                  "columns: TV time)", "", _tv_table(jobs), ""]
    header = ["job", *varying, "status", *(f"{m.upper()} {name}" for _, name in SUMMARY_STATS for m in METHODS),
              "held-out loss", "wall s"]
    rows = [[str(j.num), *(_short(j.overrides.get(k, "")) for k in varying), j.status,
             *(j.metric(f"{m}.{s}") for s, _ in SUMMARY_STATS for m in METHODS),
             fmt(j.metric("heldout_loss"), 4), j.wall_time_s] for j in jobs]
    lines += ["## Jobs", "", markdown_table(header, rows), ""]
    broken = [j for j in jobs if j.status != FINISHED or j.error]
    lines += ["## Failed, diverged, unfinished or missing", ""]
    lines += [f"- job {j.num} ({_label(j, varying) or 'no varying override'}): **{j.status}**: "
              f"{_first_line(j.error)}" for j in broken] or ["None."]
    multirun = _load_yaml(sweep_dir / "multirun.yaml")
    command = resume_command(multirun, sweep_dir.resolve()) if broken and multirun is not None else None
    if command:
        lines += ["", "Run the jobs that are not ok again, leaving finished ones untouched "
                  "(stop any run still going first):", "", f"    {command}"]
    lines += ["", "## Warnings", ""]
    lines += [f"- job {j.num} ({_label(j, varying) or 'no varying override'}): {w}"
              for j in jobs for w in j.warnings] or ["None: no fit the held-out views call suspect."]
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


HELP = """\
Summarise a Hydra multirun folder (a sweep, finished or interrupted) in DIR/report (or --out):
  report.csv   one row per job: overrides, status, error, wall time, metrics
  summary.md   counts, tables by swept setting, every job, what did not finish and
               the command that runs it again
  *.png        Dice and MSE against the swept setting, the TV-weight grid, accuracy
               against wall time, held-out loss against Dice (those that apply)
Failed, diverged, unfinished and never-started jobs are rows like the others."""


def main(argv: Sequence[str] | None = None) -> int:
    """Console entry point (``nct-report DIR [--out OUT]``); exit 2 on a bad DIR."""
    parser = argparse.ArgumentParser(prog="nct-report", description=HELP,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("dir", type=Path, help="a multirun folder (hydra.sweep.dir), e.g. outputs/multirun/...")
    parser.add_argument("--out", type=Path, default=None, help="where to write (default: DIR/report)")
    args = parser.parse_args(argv)
    try:
        report = write_report(args.dir, args.out)
    except ReportError as err:
        print(f"nct-report: error: {err}", file=sys.stderr)
        return 2
    not_ok = sum(j.status != FINISHED for j in report.jobs)
    print(f"{len(report.jobs)} jobs ({not_ok} not ok): {report.csv}, {report.summary}, "
          f"{len(report.plots)} plots in {report.csv.parent}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
