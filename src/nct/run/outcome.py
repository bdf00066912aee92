"""How a run ended, as its folder tells: ``status.json`` and, for a finished run, ``metrics.json``.

Read alike by `nct.analysis.jobs` (every job of a sweep) and `nct.analysis.benchmarking` (each benchmark run). The
files are those `nct.run.job.run_job` writes (docs/ARCHITECTURE.md); a missing or unreadable one
is an outcome too, with the reason as its error, never an exception.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

FINISHED = "ok"
UNFINISHED = "unfinished"  # no readable status.json: never started, or killed before it wrote one


@dataclass(frozen=True)
class Outcome:
    """status: the pipeline's ``ok``, ``failed`` or ``diverged``; ``running`` (still going, or killed
    mid-run); or `UNFINISHED`. metrics: ``metrics.json`` of a finished run, None otherwise or when it
    cannot be read (``error`` then says why). warnings: why the fit is suspect (status.json's)."""

    status: str
    error: str | None = None
    wall_time_s: float | None = None
    metrics: dict | None = None
    warnings: tuple[str, ...] = ()


def read_outcome(run_dir: Path) -> Outcome:
    """The outcome of the run in ``run_dir``."""
    status = _load_json(run_dir / "status.json")
    if status is None:
        return Outcome(UNFINISHED, "no status.json: never started, or killed before it began")
    if isinstance(status, str):
        return Outcome(UNFINISHED, status)
    state = str(status.get("status", UNFINISHED))
    error = status.get("error")
    wall = status.get("wall_time_s")
    wall = float(wall) if isinstance(wall, (int, float)) and not isinstance(wall, bool) else None
    listed = status.get("warnings")
    warnings = tuple(str(w) for w in listed) if isinstance(listed, list) else ()
    if state == "running":
        return Outcome(state, error or "status running: still running, or interrupted", wall)
    if state != FINISHED:
        return Outcome(state, error, wall)
    metrics = _load_json(run_dir / "metrics.json")
    if not isinstance(metrics, dict):
        return Outcome(state, "metrics.json missing or unreadable" + (f": {metrics}" if metrics else ""), wall,
                       warnings=warnings)
    return Outcome(state, error, wall, metrics, warnings)


def _load_json(path: Path) -> dict | str | None:
    """The parsed file; None when absent; the error as a string when unreadable or not an object."""
    if not path.is_file():
        return None
    try:
        loaded = json.loads(path.read_text())
    except (OSError, ValueError) as err:
        return f"unreadable {path.name}: {err}"
    return loaded if isinstance(loaded, dict) else f"unreadable {path.name}: not a JSON object"
