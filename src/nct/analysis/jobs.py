"""A Hydra multirun folder read back: its jobs (found on disk, or planned and never started), each
with its overrides, status, error, wall time, warnings and flattened metrics.

Reads every job folder under DIR (``.hydra/``, ``status.json``, ``metrics.json``, see
docs/ARCHITECTURE.md) and, from ``multirun.yaml``, the jobs that were planned but never started.
A failed, diverged, unfinished or missing job is a `Job` like any other, with its error: never dropped.
"""

from __future__ import annotations

import math
import shlex
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

from omegaconf import DictConfig, OmegaConf

from nct.run.outcome import FINISHED, read_outcome

#: Config keys the plots know.
DISPLACEMENT, TV_SPACE, TV_TIME, F_MAX = "phantom.displacement_deg", "loss.tv_space", "loss.tv_time", "model.f_max"
PLOTTED_KEYS = (DISPLACEMENT, TV_SPACE, TV_TIME, F_MAX)


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
    plan = load_yaml(sweep_dir / "multirun.yaml")
    if plan is None:  # the Optuna sweeper writes none: then DIR's subfolders must be its jobs
        dirs = [d for d in dirs if d.parent == sweep_dir]
        plans = [load_yaml(d / ".hydra" / "hydra.yaml") for d in dirs]
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
    settings = _settings(load_yaml(hydra_dir / "config.yaml"), overrides)
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
    conf = load_yaml(hydra_yaml)
    num = OmegaConf.select(conf, "hydra.job.num", default=None) if conf is not None else None
    return int(num) if isinstance(num, int) else None


def load_yaml(path: Path) -> DictConfig | None:
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


def finished(jobs: Sequence[Job]) -> list[Job]:
    """The jobs that finished ok and have metrics: the only ones plotted and aggregated."""
    return [j for j in jobs if j.status == FINISHED and j.metrics]


def union_keys(dicts: Iterable[dict]) -> list[str]:
    """Every key of ``dicts``, in first-seen order."""
    return list(dict.fromkeys(k for d in dicts for k in d))


def varying_keys(jobs: Sequence[Job]) -> list[str]:
    """The override keys whose value differs between jobs."""
    keys = union_keys(j.overrides for j in jobs)
    return [k for k in keys if len({j.overrides.get(k) for j in jobs}) > 1]


def override_label(job: Job, keys: Sequence[str]) -> str:
    """``"key=value ..."`` of the job's overrides among ``keys`` (values as `short_value`)."""
    return " ".join(f"{k}={short_value(job.overrides[k])}" for k in keys if k in job.overrides)


def short_value(value: str) -> str:
    """An override value for reading: numbers to 4 significant digits (Optuna's have 16)."""
    number = _number(value)
    return f"{number:.4g}" if number is not None and "." in value else value

