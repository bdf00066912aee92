"""A run folder holds one run: who may write into it, and its record of how the run was made.

A job is admitted into a folder that holds no run, or, with ``resume``, into one that holds a run of
the same settings (the command-line overrides, ``resume`` and Hydra's own aside), which it continues
or, finished, skips. Anything else is refused before the job writes a byte there, naming the way to
continue the run that is there. Hydra writes nothing into the folder before the job
(``hydra.output_subdir: null``, the log opened at its first line: conf/config.yaml): the job writes
``.hydra/`` itself once admitted, so a refused job leaves an existing run's files as they were.
"""

from __future__ import annotations

import json
import logging
import shutil
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from omegaconf import DictConfig, OmegaConf

from nct.errors import InputError

IGNORED_OVERRIDES = ("resume=", "hydra.")  # overrides that do not change a run's result


def read_status(folder: Path) -> dict | None:
    """The run's status.json, or None when the folder has none (no run started there); `InputError`
    when it is not readable JSON."""
    path = folder / "status.json"
    if not path.is_file():
        return None
    try:
        return json.loads(path.read_text())
    except (OSError, ValueError) as err:
        raise InputError(f"{path} is not a readable status record ({err})") from None


def settings(overrides: Sequence[str] | None) -> list[str]:
    """The overrides that define a job's result (not ``resume`` or Hydra's own), sorted."""
    return sorted(o for o in overrides or [] if not o.startswith(IGNORED_OVERRIDES))


@dataclass(frozen=True)
class Folder:
    """A job's output folder as the job found it: ``previous``, its run's status.json (None: no run);
    ``fresh``, whether it held nothing (the job's own, or an empty one); ``sweep``, whether the job is
    one of a sweep (continued by re-running the sweep, docs/SWEEPS.md)."""

    path: Path
    previous: dict | None
    fresh: bool
    sweep: bool

    @classmethod
    def found(cls, path: Path, sweep: bool) -> Folder:
        return cls(path, read_status(path), not path.is_dir() or not any(path.iterdir()), sweep)

    def continue_command(self) -> str:
        """How to continue the run in this folder with its own settings."""
        return "re-run the sweep's command with resume=true" if self.sweep else f"nct resume={self.path}"

    def admit(self, resume: bool, job_settings: list[str]) -> None:
        """Refuse (`InputError`) a job that would replace or change the run this folder holds: any job
        without ``resume``, and one with settings other than the run's."""
        if self.previous is None:
            return
        status, recorded = self.previous.get("status"), self.previous.get("overrides")
        if not resume and status == "ok":
            raise InputError(f"{self.path} already holds a finished run: choose another output folder "
                             "(resume=true skips it, untouched)")
        if not resume:
            raise InputError(f"{self.path} already holds a run (status {status}), never replaced: continue it with "
                             f"`{self.continue_command()}` (its own settings), or choose another output folder")
        if recorded != job_settings:
            raise InputError(f"resume: {self.path} holds a run with other settings ({recorded}), not {job_settings}: "
                             f"continue it with `{self.continue_command()}`, or use a new folder")

    def clear(self) -> None:
        """Remove what a refused job wrote into a folder it found empty (the folder too, unless it is
        the working directory), and the log handlers writing there: a refused run leaves no folder behind,
        and no handler that a later run in the same process (a notebook's, a test's) would write to."""
        if not self.fresh:
            return
        _drop_log_files(self.path)
        if not self.path.is_dir():
            return
        for child in self.path.iterdir():
            if child.is_dir() and not child.is_symlink():
                shutil.rmtree(child)
            else:
                child.unlink()
        if self.path.resolve() != Path.cwd().resolve():
            self.path.rmdir()


def write_record(folder: Path, cfg: DictConfig, overrides: Sequence[str] | None, hydra: DictConfig | None) -> None:
    """``.hydra/``: the composed config, the overrides and (from the command line) Hydra's own config,
    as Hydra writes them; a resumed run keeps the record it started with."""
    record = folder / ".hydra"
    if (record / "config.yaml").is_file():
        return
    record.mkdir(parents=True, exist_ok=True)
    files = {"config.yaml": cfg, "overrides.yaml": OmegaConf.create(list(overrides or []))}
    for name, node in (files | ({"hydra.yaml": hydra} if hydra is not None else {})).items():
        (record / name).write_text(OmegaConf.to_yaml(node))


def _drop_log_files(folder: Path) -> None:
    """Close and detach the root logger's file handlers whose file lies in ``folder`` (Hydra's job log)."""
    root, inside = logging.getLogger(), folder.resolve()
    for handler in list(root.handlers):
        name = getattr(handler, "baseFilename", None)
        if isinstance(handler, logging.FileHandler) and name and Path(name).resolve().is_relative_to(inside):
            root.removeHandler(handler)
            handler.close()
