"""The ``nct`` command: a Hydra application around `nct.run.job.run_job`.

Configuration errors (Hydra's composition errors, the schema's and the data's) end the command
with one line ``nct: error: ...`` on stderr and exit code 2, expected failures of the method
(no object found, divergence) with one line and exit code 1; anything else keeps its traceback.
"""

from __future__ import annotations

import time

# Before every other import: a single run's one wall time (log, status.json, metrics.json) starts
# with the process, as the user's clock does, and so do its phases' CPU seconds; claimed by the first
# job (`job_start`).
_PROCESS_START = [(time.perf_counter(), time.process_time())]

import os
import sys
from dataclasses import is_dataclass
from pathlib import Path
from typing import NoReturn

import hydra
from hydra.core.hydra_config import HydraConfig
from hydra.errors import CompactHydraException
from omegaconf import DictConfig, OmegaConf
from omegaconf.errors import (
    ConfigAttributeError,
    ConfigKeyError,
    OmegaConfBaseException,
)

from nct.cli.resume import resume_arguments
from nct.errors import InputError, MethodError
from nct.run.phases import Instant
from nct.run.schema import CONFIG_MODULE, register_configs
from nct.run.suggest import describe, unknown_key

# Hydra plugins that optional extras install: the config Hydra misses without them -> the extra.
PLUGIN_EXTRAS = {"hydra/sweeper/optuna": "optuna", "hydra/launcher/submitit": "slurm", "hydra/launcher/ray": "ray"}

# Cached: Hydra copies the resolver cache into every job, so all jobs of a sweep share one folder.
OmegaConf.register_new_resolver("nct_pid", lambda: str(os.getpid()), replace=True, use_cache=True)
register_configs()


@hydra.main(version_base="1.3", config_path=f"pkg://{CONFIG_MODULE}", config_name="config")
def app(cfg: DictConfig) -> float | None:
    """Run one reconstruction into Hydra's output folder; return the truth-free held-out loss."""
    hydra_cfg = HydraConfig.get()
    started = job_start(hydra_cfg.mode.name == "RUN")
    from nct.run.job import run_job

    try:
        return run_job(cfg, Path(hydra_cfg.runtime.output_dir), list(hydra_cfg.overrides.task), started,
                       HydraConfig.instance().cfg)
    except Exception as err:
        message = one_line(err)
        if message is None or hydra_cfg.mode.name != "RUN":
            raise  # a sweep goes on with its other jobs; main() reports the error at its end
        fail(message, exit_code(err))  # exits here, before Hydra's own report of the failed job


def job_start(single: bool) -> Instant:
    """When this job's clock starts: the process's start for the first ``single`` run of the process,
    else now (each job of a sweep, or a later run in the same process)."""
    now = Instant.now()
    first = _PROCESS_START.pop() if _PROCESS_START else None
    return Instant(*first) if single and first is not None else now


def fail(message: str, code: int = 2) -> NoReturn:
    """End the command with ``nct: error: message`` on stderr and exit ``code``."""
    print(f"nct: error: {message}", file=sys.stderr)
    sys.exit(code)


def exit_code(err: BaseException) -> int:
    """1 for an expected failure of the method on the data (status.json keeps the reason), 2 for bad input."""
    return 1 if isinstance(err, MethodError) else 2


def one_line(err: BaseException) -> str | None:
    """A configuration error or an expected method failure as one line naming the key, the fix or
    the reason; None for any other error."""
    if isinstance(err, (InputError, MethodError)):
        return str(err)
    if isinstance(err, OmegaConfBaseException):
        return describe(err)
    if not isinstance(err, CompactHydraException):
        return None
    text = str(err)
    for config, extra in PLUGIN_EXTRAS.items():
        if f"Could not find '{config}" in text:
            plugin = config.rsplit("/", 2)[-2:]
            return (f"Hydra's {plugin[1]} {plugin[0]} plugin is not installed: pip install '.[{extra}]' in a source "
                    f"checkout, or pip install 'nct[{extra}]'")
    cause = err.__cause__
    if isinstance(cause, (ConfigKeyError, ConfigAttributeError)) and is_dataclass(getattr(cause, "object_type", None)):
        return unknown_key(cause.full_key, cause.object_type)
    head, _, options = text.split("Config search path:")[0].strip().partition("\n\n")
    line = "; ".join(part.strip() for part in head.splitlines())
    if options:  # "Available options in 'group':" and one option a line
        title, *items = [part.strip() for part in options.splitlines() if part.strip()]
        line += f"; {title} {', '.join(items)}"
    return f"{line}: {describe(cause)}" if isinstance(cause, OmegaConfBaseException) else line


def main() -> None:
    """Console entry point (``nct``). Hydra re-raises errors (HYDRA_FULL_ERROR) so that configuration
    errors become one line with exit code 2; set HYDRA_FULL_ERROR=1 yourself for Hydra's own report.
    ``resume=<run folder>`` is completed with the run's recorded settings first (`nct.cli.resume`)."""
    try:
        sys.argv[1:] = resume_arguments(sys.argv[1:])
    except InputError as err:
        fail(str(err))
    if os.environ.get("HYDRA_FULL_ERROR") == "1":
        app()
        return
    os.environ["HYDRA_FULL_ERROR"] = "1"
    try:
        app()
    except Exception as err:
        message = one_line(err)
        if message is None:
            raise
        fail(message, exit_code(err))
    finally:
        del os.environ["HYDRA_FULL_ERROR"]


if __name__ == "__main__":
    main()
