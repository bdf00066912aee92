"""``nct resume=<run folder>``: a killed run continued with its own recorded settings.

The command line is completed before Hydra composes it: ``resume=<folder>``, or the longer
``hydra.run.dir=<folder> resume=true``, becomes ``hydra.run.dir=<folder> resume=true`` followed by
the overrides the run recorded in its status.json. A setting given beside it that the run was not
made with is refused here, naming it, before anything is written (`nct.run.folder` keeps the same
rule for every job).
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from pathlib import Path

from nct.errors import InputError
from nct.run.folder import IGNORED_OVERRIDES, read_status

MULTIRUN_FLAGS = ("-m", "--multirun")
PLAIN_VALUE = re.compile(r"[\w/.:~@%+\-]+")  # what Hydra's override grammar reads unquoted


def resume_arguments(args: Sequence[str]) -> list[str]:
    """``args`` (the command line after ``nct``) with a resumed run's folder and recorded settings in
    place of ``resume=<folder>``; unchanged without a run to resume (``resume=true`` alone, or a
    folder that holds no run yet: a new run there)."""
    args = list(args)
    value = _last_value(args, "resume")
    if value is None or value.lower() == "false":
        return args
    run_dir = _last_value(args, "hydra.run.dir")
    sweep = any(a in MULTIRUN_FLAGS for a in args)
    if value.lower() == "true":
        if run_dir is None or sweep:  # a new run, or each job of a sweep: run/folder.py admits them
            return args
        folder, required = Path(run_dir), False
    else:
        if sweep:
            raise InputError(f"resume={value}: a sweep resumes with its own command, hydra.sweep.dir=<folder> and "
                             "resume=true (nct-report prints it; docs/SWEEPS.md)")
        if run_dir is not None and Path(run_dir) != Path(value):
            raise InputError(f"resume={value} and hydra.run.dir={run_dir} name two folders: give one")
        folder, required = Path(value), True
    recorded = recorded_settings(folder, required)
    if recorded is None:
        return args
    given = [a for a in args if _is_setting(a)]
    other = [a for a in given if a not in recorded]
    if other:
        made = f"`{' '.join(recorded)}`" if recorded else "the defaults"
        raise InputError(f"resume: {folder} holds a run made with {made}; {' '.join(other)} would change it: "
                         f"continue it with `nct resume={folder}` alone, or start a new run in another folder")
    rest = [a for a in args if not a.startswith(("resume=", "hydra.run.dir=")) and not _is_setting(a)]
    return [*rest, f"hydra.run.dir={_quoted(str(folder))}", "resume=true", *recorded]


def recorded_settings(folder: Path, required: bool) -> list[str] | None:
    """The settings the run in ``folder`` was made with (status.json's ``overrides``); None when the
    folder holds no run and ``required`` is false, else `InputError` saying why there is none."""
    if (folder / "multirun.yaml").is_file():
        raise InputError(f"resume: {folder} is a sweep's folder: re-run the sweep's command with "
                         f"hydra.sweep.dir={folder} resume=true (nct-report prints it; docs/SWEEPS.md)")
    status = read_status(folder)
    if status is None:
        if required:
            raise InputError(f"resume: {folder} holds no run (no status.json): nothing to continue")
        return None
    recorded = status.get("overrides")
    if not isinstance(recorded, list) or not all(isinstance(o, str) for o in recorded):
        raise InputError(f"resume: {folder / 'status.json'} records no overrides list: it cannot be continued")
    return recorded


def _last_value(args: Sequence[str], key: str) -> str | None:
    """The value of the last ``key=value`` among ``args``."""
    values = [a.split("=", 1)[1] for a in args if a.startswith(f"{key}=")]
    return values[-1] if values else None


def _is_setting(arg: str) -> bool:
    """An override that changes a run's result (not a flag, ``resume`` or Hydra's own)."""
    return not arg.startswith("-") and "=" in arg and not arg.startswith(IGNORED_OVERRIDES)


def _quoted(value: str) -> str:
    """``value`` as Hydra's override grammar reads it back: quoted unless plain."""
    if PLAIN_VALUE.fullmatch(value):
        return value
    return "'" + value.replace("\\", "\\\\").replace("'", "\\'") + "'"
