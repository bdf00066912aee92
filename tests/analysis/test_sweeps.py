"""The paper's sweeps, the launchers and the Optuna search compose as documented; tiny multiruns
run end to end through `nct`, quietly (no plugin chatter, no colour codes in a pipe), the Optuna
search starting from the default configuration, and `nct-report` reads them (ok, failed and
resumed jobs)."""

from __future__ import annotations

import csv
import os
import shlex
import shutil
import subprocess
import sys
from importlib.resources import files
from pathlib import Path

import numpy as np
import pytest
import yaml
from omegaconf import DictConfig, OmegaConf

from nct.acquisition.geometry import ParallelGeometry
from nct.acquisition.io import save_sinogram
from nct.acquisition.sinogram import Sinogram
from nct.analysis.jobs import planned_overrides
from nct.analysis.report import write_report
from nct.cli.main import CONFIG_MODULE
from nct.cli.report import main as report_main
from nct.errors import InputError
from tests.conftest import compose_config

SWEEPS = Path(str(files(CONFIG_MODULE))) / "sweep"
PAPER_WEIGHTS = [0, 0.05, 0.1, 0.15, 0.3, 0.5, 0.9, 1.5, 3, 5, 10]
PAPER_DISPLACEMENTS = [0, 1, 5, 10, 20, 40, 70, 100, 120, 150, 200]
NCT = Path(sys.executable).with_name("nct")
TINY = ["debug=tiny", "logger=none", "export.png=false", "export.gif=false"]


def compose_hydra(*overrides: str) -> DictConfig:
    """The primary config with ``overrides``, including its ``hydra`` node."""
    return compose_config(list(overrides), with_hydra=True)


def swept(cfg: DictConfig) -> dict[str, list[float]]:
    """The sweep's values per key, as numbers."""
    return {k: [float(v) for v in str(vals).split(",")] for k, vals in cfg.hydra.sweeper.params.items()}


@pytest.mark.parametrize(("name", "values", "n_jobs"), [
    ("lambda_grid", {"loss.tv_space": PAPER_WEIGHTS, "loss.tv_time": PAPER_WEIGHTS}, 121),
    ("fmax", {"model.f_max": [0, 0.1, 0.2, 0.3, 0.5, 1, 2, 3, 5, 7, 10]}, 11),
    ("displacement", {"phantom.displacement_deg": PAPER_DISPLACEMENTS, "seed": list(range(5))}, 55),
])
def test_paper_sweeps_match_the_paper(name: str, values: dict, n_jobs: int):
    cfg = compose_hydra(f"sweep={name}")
    assert cfg.hydra.mode.name == "MULTIRUN"
    assert swept(cfg) == values
    assert len(planned_overrides(cfg.hydra.sweeper.params, [])) == n_jobs
    assert cfg.phantom.name == "circle" and cfg.method == "nct"
    if name != "displacement":
        assert cfg.phantom.displacement_deg == 100.0
    default = compose_hydra()  # all but the swept keys (set per job) stay at the tuned defaults
    for part in ("loss", "model", "optim", "render", "init", "heldout", "trainer", "callbacks", "image", "scanner",
                 "data", "seed"):
        assert cfg[part] == default[part], part


@pytest.mark.parametrize("name", ["lambda_grid", "fmax", "displacement"])
def test_quick_sweeps_are_small_subsets_of_the_paper_sweeps(name: str):
    full, quick = compose_hydra(f"sweep={name}"), compose_hydra(f"sweep={name}_quick")
    assert quick.hydra.mode.name == "MULTIRUN"
    settings = {k: v for k, v in swept(quick).items() if k != "seed"}  # seeds: replicates of every setting
    assert settings.keys() == swept(full).keys() - {"seed"}
    for key, values in settings.items():
        assert set(values) < set(swept(full)[key]), key
    assert len(swept(quick).get("seed", [0])) >= 2
    assert len(planned_overrides(quick.hydra.sweeper.params, [])) <= 30
    assert quick.image.size <= 64 and quick.optim.fit_steps <= 500 and not quick.optim.refine
    assert quick.hydra.launcher._target_.endswith("JoblibLauncher")  # one torch thread per job
    assert full.hydra.launcher._target_.endswith("BasicLauncher")  # full sweeps: the user picks
    assert (quick.phantom, quick.loss, quick.model.f_max) == (full.phantom, full.loss, full.model.f_max)


def test_every_sweep_file_is_covered_here():
    names = {p.stem for p in SWEEPS.glob("*.yaml")}
    assert names == {"lambda_grid", "fmax", "displacement", "lambda_grid_quick", "fmax_quick", "displacement_quick"}


@pytest.mark.parametrize(("launcher", "target", "fields"), [
    ("local", "joblib_launcher.JoblibLauncher", {"n_jobs": 2}),
    ("local_submitit", "submitit_launcher.LocalLauncher", {"timeout_min": 60, "cpus_per_task": 1}),
    ("slurm", "submitit_launcher.SlurmLauncher",
     {"partition": None, "timeout_min": 60, "cpus_per_task": 2, "mem_gb": 4, "max_num_timeout": 0}),
])
def test_launchers_compose(launcher: str, target: str, fields: dict):
    if launcher != "local":
        pytest.importorskip("hydra_plugins.hydra_submitit_launcher", reason="needs the slurm extra")
    cfg = compose_hydra("sweep=fmax_quick", f"hydra/launcher={launcher}")
    assert cfg.hydra.launcher._target_.endswith(target)
    assert {k: cfg.hydra.launcher[k] for k in fields} == fields
    if "submitit_folder" in cfg.hydra.launcher:
        assert cfg.hydra.launcher.submitit_folder.startswith(cfg.hydra.sweep.dir + "/")


def test_ray_launcher_composes():
    pytest.importorskip("hydra_plugins.hydra_ray_launcher", reason="needs the ray extra")
    cfg = compose_hydra("sweep=fmax_quick", "hydra/launcher=ray_cluster")
    assert cfg.hydra.launcher.ray.init.address == "auto" and cfg.hydra.launcher.ray.remote.num_cpus == 2


def test_optuna_search_is_truth_free_and_survives_failures():
    pytest.importorskip("hydra_plugins.hydra_optuna_sweeper", reason="needs the optuna extra")
    cfg = compose_hydra("hparams_search=tv_fmax")
    sweeper = cfg.hydra.sweeper
    assert cfg.hydra.mode.name == "MULTIRUN" and sweeper._target_.endswith("OptunaSweeper")
    assert sweeper.direction == "minimize" and sweeper.storage.url is None  # in memory
    assert sweeper.max_failure_rate == 1.0
    assert set(sweeper.params) == {"loss.tv_space", "loss.tv_time", "model.f_max"}
    assert cfg.phantom.name == "circle"


def test_optuna_search_enqueues_every_searched_key_at_its_default():
    pytest.importorskip("hydra_plugins.hydra_optuna_sweeper", reason="needs the optuna extra")
    cfg = compose_hydra("hparams_search=tv_fmax")
    first = cfg.hydra.sweeper.storage.first
    assert first.keys() == cfg.hydra.sweeper.params.keys()
    assert all(first[key] == OmegaConf.select(cfg, key) for key in first)
    assert cfg.hydra.sweeper.storage.study_name == cfg.hydra.sweeper.study_name


def test_study_storage_hands_the_defaults_out_first_and_once(tmp_path: Path):
    optuna = pytest.importorskip("optuna", reason="needs the optuna extra")
    from nct.analysis.sweeps import study_storage

    def study(url: str | None):  # as Hydra's sweeper opens it
        return optuna.create_study(study_name="s", storage=study_storage(url, "s", "minimize", first),
                                   load_if_exists=True)

    first, url = {"x": 0.0, "k": "b"}, f"sqlite:///{tmp_path / 'study.db'}"
    for where in (None, url):
        search = study(where)
        trials = [search.ask() for _ in range(3)]
        for trial in trials:
            trial.suggest_float("x", 0.0, 1.0), trial.suggest_categorical("k", ["a", "b", "c"])
            search.tell(trial, trial.params["x"])
        assert trials[0].params == first and all(t.params != first for t in trials[1:])
        assert search.best_value <= 0.0  # the best can never score below the defaults
    resumed = study(url)  # the database's study goes on: nothing enqueued again
    assert len(resumed.trials) == 3 and resumed.ask().number == 3 and resumed.trials[-1].params == {}
    with pytest.raises(InputError, match="hydra.sweeper.study_name must be set"):
        study_storage(None, None, "minimize", first)


def quiet(done: subprocess.CompletedProcess) -> str:
    """The command's output, checked for plugin chatter and colour codes."""
    out = done.stdout + done.stderr
    for noise in ("\x1b[", "setup plugin alembic", "Joblib.Parallel(", "Study name:", "Sampler:",
                  "A new study created", "ExperimentalWarning"):
        assert noise not in out, noise
    return out


def test_optuna_search_starts_from_the_defaults_quietly(tmp_path: Path):
    pytest.importorskip("hydra_plugins.hydra_optuna_sweeper", reason="needs the optuna extra")
    done = run_nct(tmp_path, "hparams_search=tv_fmax", *TINY, "hydra.sweeper.n_trials=2", "model.f_max=0.25",
                   "hydra.sweep.dir=sweep")
    assert done.returncode == 0, done.stderr[-3000:]
    out = quiet(done)
    sweep = tmp_path / "sweep"
    first = yaml.safe_load((sweep / "0" / ".hydra" / "overrides.yaml").read_text())
    assert first[:2] == ["loss.tv_space=0", "loss.tv_time=0"]  # the defaults, model.f_max fixed by the user
    assert "\t#0 : loss.tv_space=0 loss.tv_time=0 " in out and "Best value: " in out
    best = yaml.safe_load((sweep / "optimization_results.yaml").read_text())["best_value"]
    assert best <= yaml.safe_load((sweep / "0" / "metrics.json").read_text())["heldout_loss"]


# ---------------------------------------------------------------- end to end through the CLI


def run_nct(tmp_path: Path, *args: str, timeout: float = 240) -> subprocess.CompletedProcess:
    """``nct ARGS`` in ``tmp_path``, one torch thread per process (tiny jobs run several times faster)."""
    if not NCT.is_file():
        pytest.skip(f"console script {NCT} not installed")
    env = os.environ | {"OMP_NUM_THREADS": "1"}
    return subprocess.run([str(NCT), *args], cwd=tmp_path, capture_output=True, text=True, timeout=timeout, env=env)


def report_rows(sweep: Path) -> list[dict[str, str]]:
    with open(write_report(sweep).csv, newline="") as fh:
        return list(csv.DictReader(fh))


def test_joblib_multirun_then_report(tmp_path: Path):
    """FBP-only jobs: what is tested is the launcher's worker processes and the report of their folders, not
    the fit (the report's NeuralCT columns: tests/analysis/test_report.py)."""
    done = run_nct(tmp_path, "-m", "seed=0,1", *TINY, "method=fbp", "hydra/launcher=local")
    assert done.returncode == 0, done.stderr[-3000:]
    assert "\t#1 : seed=1 " in quiet(done)  # the job list stays
    # one sweep folder for the whole sweep, although each job ran in its own worker process
    (sweep,) = (tmp_path / "outputs" / "multirun").iterdir()
    assert sorted(p.name for p in sweep.iterdir()) == ["0", "1", "multirun.yaml"]
    assert report_main([str(sweep)]) == 0
    with open(sweep / "report" / "report.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert [(r["job"], r["seed"], r["status"]) for r in rows] == [("0", "0", "ok"), ("1", "1", "ok")]
    for row in rows:
        assert 0.0 <= float(row["fbp.median_dice"]) <= 1.0 and float(row["wall_time_s"]) > 0
    assert (sweep / "report" / "accuracy_vs_time.png").is_file()
    assert "2 jobs: 2 ok." in (sweep / "report" / "summary.md").read_text()


def test_failed_jobs_are_reported_and_resume_reruns_only_them(tmp_path: Path, nct):
    """In-process (``nct`` fixture, Hydra's basic launcher runs the jobs in this process): a fresh
    process would add only its start-up (test_joblib_multirun_then_report runs one)."""
    views, s = np.arange(60), (np.arange(32) - 15.5) / 32
    disc = np.tile(2 * np.sqrt(np.clip(0.2**2 - s**2, 0, None)), (60, 1)).astype(np.float32)  # a centred disc
    good = Sinogram(disc, views * 2 * np.pi / 60, views * 0.25 / 60, ParallelGeometry(32, 1 / 32))
    save_sinogram(tmp_path / "good.npz", good)
    (tmp_path / "garbage.npz").write_bytes(b"not a sinogram")
    paths = ",".join(str(tmp_path / name) for name in ("good.npz", "absent.npz", "garbage.npz"))
    sweep = tmp_path / "sweep"
    code, _, _ = nct("-m", "data=file", f"data.path={paths}", "method=fbp", *TINY, f"hydra.sweep.dir={sweep}")
    assert code != 0  # Hydra reports the failures after running every job
    rows = report_rows(sweep)
    assert [r["status"] for r in rows] == ["ok", "failed", "failed"]
    assert rows[0]["error"] == "" and all(r["error"].startswith("InputError") for r in rows[1:])
    assert "absent.npz" in rows[1]["error"] and "garbage.npz" in rows[2]["error"]
    summary = (sweep / "report" / "summary.md").read_text()
    assert summary.count("**failed**: InputError") == 2 and "3 jobs: 2 failed, 1 ok." in summary

    # the user fixes job 1's input; job 1's folder is lost (as if never started); resume as the summary says
    shutil.copy(tmp_path / "good.npz", tmp_path / "absent.npz")
    shutil.rmtree(sweep / "1")
    assert [r["status"] for r in report_rows(sweep)] == ["ok", "missing", "failed"]
    kept = [sweep / "0" / name for name in ("status.json", "metrics.json", "reconstruction.npz")]
    before = [(f.read_bytes(), f.stat().st_mtime_ns) for f in kept]
    command = (sweep / "report" / "summary.md").read_text().split("\n    nct ")[1].splitlines()[0]
    assert command.endswith(f"hydra.sweep.dir={sweep} resume=true")
    nct(*shlex.split(command))
    assert [(f.read_bytes(), f.stat().st_mtime_ns) for f in kept] == before  # not recomputed, not rewritten
    assert [r["status"] for r in report_rows(sweep)] == ["ok", "ok", "failed"]


@pytest.mark.slow
def test_submitit_local_two_jobs(tmp_path: Path):
    pytest.importorskip("hydra_plugins.hydra_submitit_launcher", reason="needs the slurm extra")
    done = run_nct(tmp_path, "-m", "seed=0,1", *TINY, "hydra/launcher=local_submitit")
    assert done.returncode == 0, done.stderr[-3000:]
    (sweep,) = (tmp_path / "outputs" / "multirun").iterdir()
    assert sorted(p.name for p in sweep.iterdir()) == [".submitit", "0", "1", "multirun.yaml"]
    assert [r["status"] for r in report_rows(sweep)] == ["ok", "ok"]
