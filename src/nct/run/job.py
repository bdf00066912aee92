"""One job's record around `nct.run.pipeline.run`: admit it into its folder (`nct.run.folder`), honour
``resume``, and keep ``status.json`` (running, ok, failed or diverged, with the wall time and warnings)
and ``.hydra/`` in the run folder.

A refused job (bad settings, a bad file, a folder that holds another run) leaves every folder as it
found it: another run's files untouched, a folder it made removed; only a sweep's job keeps a
``failed`` record, which `nct-report` lists. A run that fails once admitted (its method, a crash)
keeps its folder with the error. Bad input fails here before the pipeline (torch, matplotlib, ...)
is imported, in a third of the time.
"""

from __future__ import annotations

import json
import logging
import platform
import sys
import time
import traceback
from collections.abc import Sequence
from functools import partial
from importlib import metadata
from pathlib import Path

from omegaconf import DictConfig, OmegaConf

from nct.errors import DivergenceError, InputError, MethodError
from nct.records import write_json
from nct.run.config import validate
from nct.run.folder import Folder, settings, write_record
from nct.run.phases import Instant

log = logging.getLogger(__name__)


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


def _record(out_dir: Path, job_settings: list[str], started: Instant, status: str, error: str | None = None,
            wall: float | None = None, warnings: Sequence[str] = (), **extra) -> None:
    """Write the job's status.json (``wall`` None: the wall time so far)."""
    write_json(out_dir / "status.json", {
        "status": status, "error": error, "overrides": job_settings,
        "wall_time_s": time.perf_counter() - started.wall if wall is None else wall,
        "warnings": list(warnings), "environment": environment(), **extra}, indent=2)


def run_job(cfg: DictConfig, out_dir: Path, overrides: list[str] | None = None,
            started: Instant | None = None, hydra: DictConfig | None = None) -> float | None:
    """Admit, run and record one job; returns the held-out sinogram loss (for sweepers).

    ``overrides``: the job's command-line overrides, kept in status.json so that ``resume=true``
    continues or skips a folder only when it was made with the same settings. ``started``: when the
    job began (None: now; `nct.cli.main` gives a single run's process start), the start of its one wall
    time, which the log, status.json and metrics.json give alike, and of its phases' CPU seconds.
    ``hydra``: Hydra's config of the job (from the command line), written beside the job's config in
    ``.hydra/``; its mode tells a sweep's job. status.json's ``warnings``: those `nct.run.pipeline.run`
    returns (times, motion the data do not determine, a file's geometry, why the fit is suspect).
    """
    started = Instant.now() if started is None else started
    job_settings = settings(overrides)
    mode = OmegaConf.select(hydra, "hydra.mode", default=None) if hydra is not None else None
    folder = Folder.found(out_dir, getattr(mode, "name", mode) == "MULTIRUN")
    record = partial(_record, out_dir, job_settings, started)
    try:
        conf = validate(cfg)
        folder.admit(conf.resume, job_settings)
    except InputError as err:
        if folder.fresh and folder.sweep:  # the sweep's report lists the refused job
            write_record(out_dir, cfg, overrides, hydra)
            record("failed", f"InputError: {err}")
        else:
            folder.clear()  # a folder the job made; any other stays as it was
        raise
    if conf.resume and folder.previous is not None and folder.previous.get("status") == "ok":
        print(f"resume: {out_dir} already holds this finished run: skipped, untouched")  # not logged: its log is kept
        return json.loads((out_dir / "metrics.json").read_text()).get("heldout_loss")
    write_record(out_dir, cfg, overrides, hydra)
    record("running")
    log.info("outputs in %s; loading torch ...", out_dir)  # the first line: the imports take seconds
    try:
        from nct.run.pipeline import (
            run,  # lazy: its imports are ~3 s of start-up, after validation
        )

        result, warnings = run(conf, cfg, out_dir, started)
    except InputError as err:  # found by the pipeline (a file's checks, the memory, the device): refused too
        if folder.fresh and not folder.sweep:
            folder.clear()
        else:
            record("failed", f"InputError: {err}")
        raise
    except MethodError as err:  # expected: the reason is the whole story
        record("diverged" if isinstance(err, DivergenceError) else "failed", f"{type(err).__name__}: {err}")
        raise
    except BaseException as err:
        record("failed", f"{type(err).__name__}: {err}", traceback=traceback.format_exc())
        raise
    write_json(out_dir / "metrics.json", result, indent=2)
    record("ok", wall=result["wall_time_s"], warnings=warnings, **_model(result))
    _log_summary(result, warnings, out_dir)
    return result.get("heldout_loss")


def _model(result: dict) -> dict:
    """status.json's ``model``: the scene model and motion rung the run ended with (NeuralCT runs only)."""
    if "model" not in result:
        return {}
    return {"model": {key: result["model"][key] for key in ("n_objects", "background", "motion")}}


def _log_summary(result: dict, warnings: list[str], out_dir: Path) -> None:
    from nct.run.metrics import (
        quality_line,  # lazy: scikit-image's metrics, loaded by the pipeline by then
    )

    for name in ("fbp", "nct"):
        if name in result:
            log.info("%s: %s", name.upper(), quality_line(result[name]))
    if "model" in result:
        model = result["model"]
        log.info("model: %d object%s, background %s, motion %s (selection.csv)", model["n_objects"],
                 "s" * (model["n_objects"] > 1), model["background"], model["motion"])
    for line in warnings:
        log.warning("%s", line)
    log.info("wall time %.1f s (as in status.json and metrics.json); outputs in %s",
             result["wall_time_s"], out_dir)
