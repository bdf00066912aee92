"""A run folder holds one run: a job that would replace or change it is refused (naming how to continue
it), a refused job removes only a folder it made, and the .hydra/ record is written once."""

from __future__ import annotations

import json
import logging
from pathlib import Path

import pytest
from omegaconf import OmegaConf

from nct.errors import InputError
from nct.run.folder import Folder, read_status, settings, write_record


def folder_with(tmp_path: Path, status: str | None, overrides: list[str] = (), sweep: bool = False) -> Folder:
    path = tmp_path / "run"
    path.mkdir(exist_ok=True)
    if status is not None:
        (path / "status.json").write_text(json.dumps({"status": status, "overrides": list(overrides)}))
    return Folder.found(path, sweep)


def test_settings_leave_out_resume_and_hydras_own():
    assert settings(["seed=2", "resume=true", "hydra.run.dir=x", "data=file"]) == ["data=file", "seed=2"]


@pytest.mark.parametrize("status", ["ok", "running", "failed", "diverged"])
def test_a_new_run_never_replaces_another(tmp_path, status):
    folder = folder_with(tmp_path, status, ["seed=1"])
    expected = "already holds a finished run" if status == "ok" else (
        f"already holds a run \\(status {status}\\), never replaced: continue it with `nct resume={folder.path}`")
    with pytest.raises(InputError, match=expected):
        folder.admit(resume=False, job_settings=["seed=1"])
    folder.admit(resume=True, job_settings=["seed=1"])  # the same settings continue it
    with pytest.raises(InputError, match=r"holds a run with other settings \(\['seed=1'\]\), not \['seed=2'\]"):
        folder.admit(resume=True, job_settings=["seed=2"])


def test_a_sweeps_job_is_continued_by_its_sweep(tmp_path):
    with pytest.raises(InputError, match="continue it with `re-run the sweep's command with resume=true`"):
        folder_with(tmp_path, "running", sweep=True).admit(resume=False, job_settings=[])


def test_an_empty_folder_admits_any_run(tmp_path):
    folder = folder_with(tmp_path, None)
    assert folder.fresh and folder.previous is None
    folder.admit(resume=False, job_settings=["seed=3"])


def test_a_refused_job_removes_only_a_folder_it_found_empty(tmp_path, monkeypatch):
    fresh = folder_with(tmp_path, None)
    (fresh.path / ".hydra").mkdir()
    (fresh.path / "main.log").write_text("reading ...")
    fresh.clear()
    assert not fresh.path.exists()
    kept = folder_with(tmp_path, "running")
    kept.clear()
    assert read_status(kept.path)["status"] == "running"
    (tmp_path / "here").mkdir()
    monkeypatch.chdir(tmp_path / "here")  # the working directory is emptied, never removed
    here = Folder.found(Path("."), sweep=False)
    (tmp_path / "here" / "main.log").write_text("reading ...")
    here.clear()
    assert here.fresh and (tmp_path / "here").is_dir() and not any((tmp_path / "here").iterdir())


def test_a_refused_job_leaves_no_log_handler_writing_into_its_folder(tmp_path):
    """Hydra's job log (a FileHandler opened at its first line) goes with the folder: a later run in the same
    process logging to it would fail on the missing folder (a test run after a refused one did)."""
    fresh, elsewhere = folder_with(tmp_path, None), logging.FileHandler(tmp_path / "other.log", delay=True)
    ours = logging.FileHandler(fresh.path / "main.log", delay=True)
    root = logging.getLogger()
    for handler in (ours, elsewhere):
        root.addHandler(handler)
    try:
        fresh.clear()
        assert not fresh.path.exists() and ours not in root.handlers and elsewhere in root.handlers
    finally:
        for handler in (ours, elsewhere):
            root.removeHandler(handler)
            handler.close()


def test_the_record_is_written_once(tmp_path):
    write_record(tmp_path, OmegaConf.create({"seed": 1}), ["seed=1"], OmegaConf.create({"hydra": {"mode": "RUN"}}))
    write_record(tmp_path, OmegaConf.create({"seed": 2}), ["seed=2", "resume=true"], None)
    assert OmegaConf.load(tmp_path / ".hydra" / "config.yaml") == {"seed": 1}
    assert list(OmegaConf.load(tmp_path / ".hydra" / "overrides.yaml")) == ["seed=1"]
    assert OmegaConf.load(tmp_path / ".hydra" / "hydra.yaml").hydra.mode == "RUN"


def test_an_unreadable_status_is_named(tmp_path):
    (tmp_path / "status.json").write_text("{not json")
    with pytest.raises(InputError, match="status.json is not a readable status record"):
        read_status(tmp_path)
