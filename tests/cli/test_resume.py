"""``nct resume=<folder>``: a killed run continues from its folder alone, with its own recorded
settings, to the uninterrupted result; a refused resume or run leaves every byte of the folder as it was."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from nct.cli.resume import resume_arguments
from nct.errors import InputError

# A tiny run whose sinogram fit lasts a second or two (80 steps), long enough to be killed in; seed=1: a setting the
# resume must take from the run's record.
RUN = ["debug=tiny", "logger=none", "threads=1", "export.gif=false", "export.png=false", "export.tiff=false",
       "optim.fit_steps=80", "seed=1", "data.n_objects=1", "background=none"]


def files(folder: Path) -> dict[str, bytes | None]:
    """Every file's bytes and every folder (None) below ``folder``, by relative path."""
    return {str(p.relative_to(folder)): p.read_bytes() if p.is_file() else None for p in sorted(folder.rglob("*"))}


def killed_run(folder: Path) -> None:
    """``nct RUN`` into ``folder`` in its own process, killed (SIGKILL) once its first stage's checkpoint
    is written: the folder as a killed run leaves it (status running, the fit's stage unfinished)."""
    proc = subprocess.Popen([sys.executable, "-m", "nct.cli.main", *RUN, f"hydra.run.dir={folder}"],
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
                            env=os.environ | {"OMP_NUM_THREADS": "1"})
    first, deadline = folder / "checkpoints" / "free_init" / "stage.json", time.monotonic() + 300
    while not first.is_file():
        assert proc.poll() is None, proc.stderr.read()[-2000:]
        assert time.monotonic() < deadline
        time.sleep(0.02)
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    status = json.loads((folder / "status.json").read_text())
    assert status["status"] == "running" and not (folder / "checkpoints" / "free_fit" / "stage.json").exists()


def test_a_killed_run_resumes_from_its_folder_alone_and_refusals_touch_nothing(nct, tmp_path):
    killed, whole = tmp_path / "killed", tmp_path / "whole"
    killed_run(killed)
    before = files(killed)
    refusals = {  # command -> what its one line says
        (f"resume={killed}", "seed=2"): "would change it: continue it with `nct resume=",
        (f"hydra.run.dir={killed}", "resume=true", "seed=2"): "would change it",
        (f"hydra.run.dir={killed}", *RUN): f"never replaced: continue it with `nct resume={killed}`",
        (f"hydra.run.dir={killed}", "debug=tiny", "logger=none"): "never replaced",
    }
    for args, says in refusals.items():
        code, _, err = nct(*args)
        assert code == 2 and says in err and err.count("\n") == 1, err
        assert files(killed) == before, args
    code, _, err = nct(f"resume={killed}")  # the README's command: the folder alone
    assert code == 0, err
    stages = json.loads((killed / "metrics.json").read_text())["stages"]
    assert stages["free_init"]["resumed"] and "resumed" not in stages["free_fit"]
    assert nct(*RUN, f"hydra.run.dir={whole}")[0] == 0
    np.testing.assert_array_equal(np.load(killed / "reconstruction.npz")["nct"],
                                  np.load(whole / "reconstruction.npz")["nct"])
    finished = files(killed)
    code, out, _ = nct(f"hydra.run.dir={killed}", "resume=true")  # the longer form, no settings repeated
    assert code == 0 and "already holds this finished run: skipped, untouched" in out
    assert nct(f"hydra.run.dir={killed}", *RUN)[0] == 2
    assert files(killed) == finished


RECORDED = ["debug=tiny", "seed=1"]


@pytest.fixture
def run_folder(tmp_path: Path) -> Path:
    (tmp_path / "status.json").write_text(json.dumps({"status": "running", "overrides": RECORDED}))
    return tmp_path


def test_the_folder_alone_names_the_run_and_its_settings(run_folder):
    completed = [f"hydra.run.dir={run_folder}", "resume=true", *RECORDED]
    assert resume_arguments([f"resume={run_folder}"]) == completed
    assert resume_arguments([f"hydra.run.dir={run_folder}", "resume=true"]) == completed
    assert resume_arguments([f"resume={run_folder}", "seed=1", "--cfg", "job"]) == ["--cfg", "job", *completed]
    for unchanged in (["resume=true"], ["seed=2"], ["resume=false", f"hydra.run.dir={run_folder}"],
                      ["-m", f"hydra.sweep.dir={run_folder}", "resume=true"]):
        assert resume_arguments(unchanged) == unchanged


def test_a_folder_without_a_run_or_of_a_sweep_is_named(tmp_path, run_folder):
    assert resume_arguments([f"hydra.run.dir={tmp_path / 'new'}", "resume=true"])[-1] == "resume=true"  # a new run
    with pytest.raises(InputError, match="holds no run \\(no status.json\\): nothing to continue"):
        resume_arguments([f"resume={tmp_path / 'new'}"])
    (run_folder / "multirun.yaml").write_text("hydra: {}")
    with pytest.raises(InputError, match="is a sweep's folder: re-run the sweep's command"):
        resume_arguments([f"resume={run_folder}"])
    with pytest.raises(InputError, match="a sweep resumes with its own command"):
        resume_arguments(["-m", f"resume={run_folder}"])
    with pytest.raises(InputError, match="name two folders"):
        resume_arguments([f"resume={run_folder}", f"hydra.run.dir={tmp_path / 'other'}"])


def test_a_path_hydra_cannot_read_plain_is_quoted(tmp_path):
    odd = tmp_path / "my run's (2)"
    odd.mkdir()
    (odd / "status.json").write_text(json.dumps({"status": "failed", "overrides": []}))
    assert resume_arguments([f"resume={odd}"])[0] == "hydra.run.dir='" + str(odd).replace("'", "\\'") + "'"
