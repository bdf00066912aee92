"""One job's record around `nct.run.pipeline.run`: validate the config, honour ``resume``, and keep
``status.json`` (running, ok, failed or diverged, with the wall time and warnings) in the run folder.

A run that fails records its error there and leaves every other run's folder untouched. Bad input
fails here before the pipeline (torch, matplotlib, ...) is imported, in a third of the time.
"""

from __future__ import annotations

import json
import logging
import platform
import sys
import time
import traceback
from collections.abc import Sequence
from importlib import metadata
from pathlib import Path

from omegaconf import DictConfig

from nct.errors import DivergenceError, InputError, MethodError
from nct.run.config import validate
from nct.run.phases import Instant

log = logging.getLogger(__name__)


def _write_json(path: Path, payload: dict) -> None:
    tmp = path.with_suffix(".tmp")
    tmp.write_text(json.dumps(payload, indent=2))
    tmp.replace(path)


def read_status(out_dir: Path) -> dict | None:
    """The run's status.json, or None when the folder has none (never started)."""
    path = out_dir / "status.json"
    return json.loads(path.read_text()) if path.is_file() else None


IGNORED_OVERRIDES = ("resume=", "hydra.")
PACKAGES = ("nct", "torch", "numpy", "scipy", "scikit-image", "scikit-learn", "lightning", "hydra-core")


def environment() -> dict[str, str]:
    """Python's and the numerical packages' versions: the same seed gives the same metrics only
    with the same versions (a solver or a random stream can change between releases)."""
    def version(name: str) -> str:
        try:
            return metadata.version(name)
        except metadata.PackageNotFoundError:  # e.g. nct run from a source tree that was never installed
            return "not installed"

    versions = {"python": platform.python_version(), **{name: version(name) for name in PACKAGES}}
    torch = sys.modules.get("torch")  # once the run imported it: its build (+cpu, +cu130), which some metadata drop
    return versions | ({"torch": torch.__version__} if torch is not None else {})


def _settings(overrides: list[str] | None) -> list[str]:
    """The overrides that define a job's result (not ``resume`` or Hydra's own), sorted."""
    return sorted(o for o in overrides or [] if not o.startswith(IGNORED_OVERRIDES))


def run_job(cfg: DictConfig, out_dir: Path, overrides: list[str] | None = None,
            started: Instant | None = None) -> float | None:
    """Validate, run and record one job; returns the held-out sinogram loss (for sweepers).

    ``overrides``: the job's command-line overrides, kept in status.json so that ``resume=true``
    skips a finished folder only when it was made with the same settings. ``started``: when the
    job began (None: now; `nct.cli.main` gives a single run's process start), the start of its one
    wall time, which the log, status.json and metrics.json give alike, and of its phases' CPU seconds.
    status.json's ``warnings``: those `nct.run.pipeline.run` returns (motion the data do not determine,
    a geometry the views contradict, why the fit is suspect), empty when nothing says so.
    """
    started = Instant.now() if started is None else started
    out_dir.mkdir(parents=True, exist_ok=True)
    settings = _settings(overrides)

    def record(status: str, error: str | None = None, wall: float | None = None, warnings: Sequence[str] = (),
               **extra) -> None:
        _write_json(out_dir / "status.json", {
            "status": status, "error": error, "overrides": settings,
            "wall_time_s": time.perf_counter() - started.wall if wall is None else wall,
            "warnings": list(warnings), "environment": environment(), **extra})

    previous = read_status(out_dir)
    try:
        conf = validate(cfg)
        if previous is not None and previous.get("status") == "ok":
            if not conf.resume:
                raise InputError(f"{out_dir} already holds a finished run: pass resume=true to keep it and skip, "
                                 "or choose another output folder")
    except InputError as err:
        if previous is None or previous.get("status") != "ok":
            record("failed", f"InputError: {err}")
        raise
    if conf.resume and previous is not None and previous.get("overrides") != settings:
        # Left as it is: that run's record and checkpoints belong to its own settings.
        raise InputError(f"resume: {out_dir} holds a run with other settings ({previous.get('overrides')}), "
                         f"not {settings}: it cannot continue this one; use a new folder")
    if conf.resume and previous is not None and previous.get("status") == "ok":
        log.info("resume: %s already finished, skipped", out_dir)
        return json.loads((out_dir / "metrics.json").read_text()).get("heldout_loss")
    record("running")
    try:
        from nct.run.pipeline import run  # lazy: its imports are ~3 s of start-up, after validation

        result, warnings = run(conf, cfg, out_dir, started)
    except MethodError as err:  # expected: the reason is the whole story
        record("diverged" if isinstance(err, DivergenceError) else "failed", f"{type(err).__name__}: {err}")
        raise
    except BaseException as err:
        record("failed", f"{type(err).__name__}: {err}", traceback=traceback.format_exc())
        raise
    _write_json(out_dir / "metrics.json", result)
    record("ok", wall=result["wall_time_s"], warnings=warnings)
    _log_summary(result, warnings, out_dir)
    return result.get("heldout_loss")


def _log_summary(result: dict, warnings: list[str], out_dir: Path) -> None:
    from nct.run.metrics import quality_line  # lazy: scikit-image's metrics, loaded by the pipeline by then

    for name in ("fbp", "nct"):
        if name in result:
            log.info("%s: %s", name.upper(), quality_line(result[name]))
    for line in warnings:
        log.warning("%s", line)
    log.info("wall time %.1f s (as in status.json and metrics.json); outputs in %s",
             result["wall_time_s"], out_dir)
