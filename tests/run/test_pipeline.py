"""One run end to end (FBP path, in-process), the sinogram file path, resume and the CLI's errors."""

import json
import logging
import shutil
import subprocess
import sys
import time
from importlib import metadata

import numpy as np
import pytest
import torch
from hydra.types import RunMode
from skimage.draw import ellipse
from skimage.transform import radon
from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

from nct.analysis.benchmarking import QUIET
from nct.errors import InputError
from nct.run.config import validate
from nct.run.job import run_job
from nct.run.phases import Instant
from nct.run.pipeline import acquire
from nct.run.reconstruct import reconstruct_scan
from tests.conftest import TINY, compose_config


def read(path):
    return json.loads(path.read_text())


def test_a_run_of_fbp_alone_loads_no_lightning():
    """The pipeline up to FBP imports no fitting library (Lightning: 2.3 s of a 12 s FBP run's start-up)."""
    code = "import sys, nct.run.pipeline; print(sorted(m for m in ('lightning', 'torch') if m in sys.modules))"
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0 and done.stdout.split() == ["['torch']"], done.stderr[-2000:]


def test_fbp_run_writes_every_output(tiny_cfg, run_dir, monkeypatch):
    installed = metadata.version  # an install whose metadata drops torch's build (+cu130), as seen on a GPU host
    monkeypatch.setattr(metadata, "version", lambda name: "2.0" if name == "torch" else installed(name))
    run_job(tiny_cfg("method=fbp"), run_dir)
    status = read(run_dir / "status.json")
    assert status["status"] == "ok" and status["warnings"] == []  # FBP alone: no fit to doubt
    assert status["environment"]["torch"] == torch.__version__ and status["environment"]["numpy"] == np.__version__
    metrics = read(run_dir / "metrics.json")
    assert set(metrics["fbp"]) >= {"median_dice", "iqr_dice", "median_mse", "share_mse_lt_0.005", "share_dice_gt_0.85"}
    rec = np.load(run_dir / "reconstruction.npz")
    assert rec["fbp"].shape == (6, 32, 32) and rec["times"].shape == (6,)
    for name in ("sinogram.npz", "strip.png", "metrics.png", "movie.gif", "frames/fbp.tiff", "frames/truth.tiff"):
        assert (run_dir / name).is_file(), name
    assert any((run_dir / "tb").iterdir())


def test_fbp_of_static_scene_matches_truth(tiny_cfg, run_dir):
    cfg = tiny_cfg("method=fbp", "experiment=static", "image.size=128", "scanner.n_bins=128",
                   "scanner.views_per_rotation=360", *QUIET)
    run_job(cfg, run_dir)
    assert read(run_dir / "metrics.json")["fbp"]["median_dice"] >= 0.98


def radon_file(path, n=129):
    """A static ellipse sinogram written by scikit-image's radon (an independent projector)."""
    img = np.zeros((n, n), np.float32)
    rr, cc = ellipse(50, 75, 25, 14, shape=img.shape, rotation=np.deg2rad(25))
    img[rr, cc] = 1.0
    theta = np.linspace(0.0, 360.0, 400, endpoint=False)
    pixel = 1.0 / n
    sino = (radon(img, theta, circle=True).T * pixel).astype(np.float32)
    np.savez(path, sinogram=sino, angles=np.deg2rad(theta), times=np.linspace(0, 0.25, 400, endpoint=False),
             bin_spacing=pixel, truth=img[None], truth_times=np.array([0.125]), truth_extent=1.0)
    return img


def test_independent_sinogram_file_reconstructs(tiny_cfg, run_dir, tmp_path):
    img = radon_file(tmp_path / "scan.npz")
    run_job(tiny_cfg("method=fbp", "data=file", f"data.path={tmp_path / 'scan.npz'}", "fbp.window_deg=360", *QUIET),
            run_dir)
    rec = np.load(run_dir / "reconstruction.npz")
    assert rec["fbp"].shape == (1,) + img.shape
    assert read(run_dir / "metrics.json")["fbp"]["median_dice"] >= 0.98


def test_a_file_in_milliseconds_is_warned_of_and_runs_quiet_when_stated(tiny_cfg, tmp_path):
    """Times in ms read as seconds put a turn at 250 s: a warning naming times and the fix; with
    data.times_unit=ms the same file runs quiet, its frames at the times (s) of the file in seconds."""
    radon_file(tmp_path / "s.npz")
    with np.load(tmp_path / "s.npz") as f:
        np.savez(tmp_path / "ms.npz", **(dict(f) | {"times": f["times"] * 1e3, "truth_times": f["truth_times"] * 1e3}))
    runs = {"s": ("s.npz", "null"), "ms": ("ms.npz", "null"), "stated": ("ms.npz", "ms")}
    for name, (file, unit) in runs.items():
        run_job(tiny_cfg("method=fbp", "data=file", f"data.path={tmp_path / file}", f"data.times_unit={unit}",
                         "fbp.window_deg=360", *QUIET), tmp_path / name)
    warnings = {name: read(tmp_path / name / "status.json")["warnings"] for name in runs}
    assert warnings["s"] == warnings["stated"] == []
    assert len(warnings["ms"]) == 1 and warnings["ms"][0].startswith("times: a gantry turn every 250 s")
    assert "data.times_unit=ms" in warnings["ms"][0]
    np.testing.assert_allclose(np.load(tmp_path / "stated" / "reconstruction.npz")["times"],
                               np.load(tmp_path / "s" / "reconstruction.npz")["times"], rtol=1e-12)
    with pytest.raises(InputError, match=r"key 'times': a gantry turn every 0.25 ms .* set data.times_unit"):
        run_job(tiny_cfg("method=fbp", "data=file", f"data.path={tmp_path}/s.npz", "data.times_unit=ms", *QUIET),
                tmp_path / "wrong")


def test_only_a_file_is_checked_for_a_wrong_geometry(tiny_cfg, tmp_path, monkeypatch):
    """A simulation's geometry is the one that made its data: a geometry warning there could only be
    false, so only a file's run carries them."""
    monkeypatch.setattr("nct.run.reconstruct.geometry_warnings", lambda *args: ["suspect geometry: as if shifted"])
    radon_file(tmp_path / "scan.npz")
    run_job(tiny_cfg("method=fbp", *QUIET), tmp_path / "simulated")
    run_job(tiny_cfg("method=fbp", "data=file", f"data.path={tmp_path / 'scan.npz'}", *QUIET), tmp_path / "file")
    assert read(tmp_path / "simulated" / "status.json")["warnings"] == []
    assert read(tmp_path / "file" / "status.json")["warnings"] == ["suspect geometry: as if shifted"]


def test_bad_file_fails_cleanly_and_keeps_earlier_outputs(tiny_cfg, run_dir, tmp_path):
    run_job(tiny_cfg("method=fbp", "logger=none"), run_dir)
    before = {p: p.read_bytes() for p in run_dir.rglob("*") if p.is_file()}
    np.savez(tmp_path / "bad.npz", sinogram=np.zeros((4, 4), np.float32), angles=np.zeros(4), times=np.zeros(4))
    with pytest.raises(InputError, match="'bin_spacing'"):
        run_job(tiny_cfg("method=fbp", "data=file", f"data.path={tmp_path / 'bad.npz'}"), tmp_path / "other")
    assert not (tmp_path / "other").exists()  # a refused file leaves no run folder
    with pytest.raises(InputError, match="already holds a finished run"):
        run_job(tiny_cfg("method=fbp", "logger=none"), run_dir)
    assert {p: p.read_bytes() for p in run_dir.rglob("*") if p.is_file()} == before


def test_one_wall_time_from_the_start_to_the_outputs_in_log_status_and_metrics(tiny_cfg, run_dir, caplog):
    started = Instant(time.perf_counter() - 100.0, time.process_time())  # e.g. the process's start, given by the CLI
    with caplog.at_level(logging.INFO, logger="nct.run.job"):
        run_job(tiny_cfg("method=fbp", "logger=none"), run_dir, started=started)
    wall = read(run_dir / "status.json")["wall_time_s"]
    assert read(run_dir / "metrics.json")["wall_time_s"] == wall
    assert 100.0 < wall < time.perf_counter() - started.wall
    assert any(r.getMessage().startswith(f"wall time {wall:.1f} s") for r in caplog.records)
    phases = read(run_dir / "metrics.json")["phases"]
    assert list(phases["wall_s"]) == ["startup", "data", "checks", "fbp", "metrics", "exports"]
    assert phases["wall_s"]["startup"] > 100.0  # from the given start
    assert 0.99 * wall < sum(phases["wall_s"].values()) <= wall  # laps of one stopwatch: nothing unaccounted


def test_phases_say_where_a_reconstructions_time_went(tiny_cfg, run_dir):
    """metrics.json ``phases``: wall and CPU seconds of each phase, in the order the run met them, each
    >= 0, adding up to the wall time; the tournament holds its stages' fits (metrics.json ``stages``)."""
    run_job(tiny_cfg("optim.refine=true", "optim.refine_init_steps=3", "optim.refine_fit_steps=3", *QUIET), run_dir)
    metrics = read(run_dir / "metrics.json")
    wall, cpu = metrics["phases"]["wall_s"], metrics["phases"]["cpu_s"]
    assert list(wall) == list(cpu) == ["startup", "data", "checks", "fbp", "initialisation", "tournament",
                                       "refinement", "metrics", "exports"]
    assert all(v >= 0 for v in [*wall.values(), *cpu.values()])
    assert 0.99 * metrics["wall_time_s"] < sum(wall.values()) <= metrics["wall_time_s"]
    stages = {name: s["wall_time_s"] for name, s in metrics["stages"].items()}
    assert set(stages) == {"free_init", "free_fit", "refine_init", "refine_fit"}
    assert stages["free_init"] + stages["free_fit"] <= wall["tournament"]
    assert stages["refine_init"] + stages["refine_fit"] <= wall["refinement"]


def test_each_phase_says_what_it_starts(tiny_cfg, run_dir, caplog):
    """Progress from the first seconds on: a line before the imports (torch: seconds) and at each phase."""
    with caplog.at_level(logging.INFO):
        run_job(tiny_cfg(*QUIET), run_dir)
    lines = [r.getMessage() for r in caplog.records
             if r.name in ("nct.run.job", "nct.run.pipeline", "nct.run.reconstruct")]
    assert lines[:5] == [f"outputs in {run_dir}; loading torch ...",
                         "simulating the circle phantom: 60 views of 32 bins ...",
                         "FBP: 6 frames of 32 x 32 pixels ...",
                         "NeuralCT: initialising (the FBP frames segmented, the starts judged on the views) ...",
                         "writing the frames, pictures and movie ..."]
    order = {r.getMessage().split(" ")[0]: i for i, r in reversed(list(enumerate(caplog.records)))}  # first of each
    assert order["NeuralCT:"] < order["stage"] < order["writing"]


@pytest.mark.parametrize(("steps", "warned"), [(5, True), (100, False)])
def test_a_poor_fit_warns_and_a_good_one_does_not(tiny_cfg, run_dir, caplog, steps: int, warned: bool):
    """At tiny sizes, 5 steps leave the held-out views worse explained than by FBP; 100 + 200 do not."""
    with caplog.at_level(logging.WARNING, logger="nct.run.job"):
        run_job(tiny_cfg(f"optim.init_steps={steps}", f"optim.fit_steps={2 * steps}", "logger=none",
                         "export.gif=false", "export.tiff=false", "export.png=false"), run_dir)
    status, metrics = read(run_dir / "status.json"), read(run_dir / "metrics.json")
    assert status["status"] == "ok" and bool(status["warnings"]) == warned
    assert [r.getMessage() for r in caplog.records if r.levelno == logging.WARNING] == status["warnings"]
    assert (metrics["heldout_loss"] > metrics["heldout_fbp_loss"]) == warned
    assert not any("file" in line for line in status["warnings"])  # a simulation's geometry made its data


@pytest.mark.parametrize("background", ["none", "image"])
def test_a_run_writes_the_whole_image_beside_its_masks(tiny_cfg, run_dir, background):
    """reconstruction.npz: the NCT frames are the whole image, the background (if any) plus each object's
    a(k) inside its mask (``nct_masks``); ``nct_background`` is there only with background=image; status.json
    names the model the run ended with."""
    run_job(tiny_cfg(f"background={background}", *QUIET), run_dir)
    rec, metrics = np.load(run_dir / "reconstruction.npz"), read(run_dir / "metrics.json")
    assert read(run_dir / "status.json")["model"] == {"n_objects": 1, "background": background, "motion": "free"}
    masks, frames = rec["nct_masks"], rec["nct"]
    assert masks.dtype == bool and masks.shape == (6, 1, 32, 32) and 0 < masks.mean() < 0.5
    assert ("nct_background" in rec) == (background == "image")
    under = rec["nct_background"] if background == "image" else np.zeros((32, 32), np.float32)
    objects = frames - under  # a(k) x occupancy: above a/2 inside the mask, except on the 1-pixel ramp
    a = metrics["intensities"][0]
    agree = (objects > a / 2) == masks[:, 0]
    assert agree.mean() > 0.97


def test_resume_skips_a_finished_job(tiny_cfg, run_dir):
    run_job(tiny_cfg("method=fbp", *QUIET), run_dir)
    stamp = (run_dir / "status.json").stat().st_mtime_ns
    run_job(tiny_cfg("method=fbp", *QUIET, "resume=true"), run_dir)
    assert (run_dir / "status.json").stat().st_mtime_ns == stamp


def test_seed_reproduces_noisy_data(tiny_cfg, tmp_path):
    for name in ("a", "b"):
        run_job(tiny_cfg("method=fbp", *QUIET, "data.noise_i0=1000", "seed=0"), tmp_path / name)
    a, b = (np.load(tmp_path / n / "sinogram.npz")["sinogram"] for n in ("a", "b"))
    np.testing.assert_array_equal(a, b)


def test_cli_bad_value_is_one_line_and_exit_2(tmp_path):
    proc = subprocess.run([sys.executable, "-m", "nct.cli.main", "scanner.views_per_rotation=-5",
                           f"hydra.run.dir={tmp_path}/run"], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2
    assert proc.stderr.strip() == "nct: error: scanner.views_per_rotation must be >= 2, got -5"


def test_resume_refuses_a_folder_made_with_other_settings(tiny_cfg, run_dir):
    run_job(tiny_cfg("method=fbp", *QUIET, "seed=1"), run_dir, ["method=fbp", "seed=1"])
    with pytest.raises(InputError, match="other settings"):
        run_job(tiny_cfg("method=fbp", *QUIET, "seed=2", "resume=true"), run_dir,
                ["method=fbp", "seed=2", "resume=true"])
    assert read(run_dir / "status.json")["overrides"] == ["method=fbp", "seed=1"]


def test_an_invalid_value_leaves_no_folder_and_a_sweeps_job_a_failed_record(tiny_cfg, run_dir, tmp_path):
    """A refused single run leaves no folder behind (the error is its one line); a sweep's refused job
    records why in its own folder, which nct-report lists."""
    run_dir.mkdir()  # as Hydra makes it before the job
    with pytest.raises(InputError, match="phantom.displacement_deg"):
        run_job(tiny_cfg("phantom.displacement_deg=400"), run_dir)
    assert not run_dir.exists()
    sweep = compose_config(TINY, with_hydra=True)
    sweep.hydra.mode = RunMode.MULTIRUN
    with pytest.raises(InputError, match="phantom.displacement_deg"):
        run_job(tiny_cfg("phantom.displacement_deg=400"), tmp_path / "0", ["phantom.displacement_deg=400"], hydra=sweep)
    status = read(tmp_path / "0" / "status.json")
    assert status["status"] == "failed" and "phantom.displacement_deg" in status["error"]
    assert status["warnings"] == [] and (tmp_path / "0" / ".hydra" / "hydra.yaml").is_file()


def test_file_without_truth_spans_the_detector(tiny_cfg, run_dir, tmp_path):
    """Without a truth the field of view is the detector's width, in the file's own unit (here mm)."""
    radon_file(tmp_path / "scan.npz")
    with np.load(tmp_path / "scan.npz") as f:
        mm = {"sinogram": f["sinogram"] * np.float32(0.02 * 200), "angles": f["angles"], "times": f["times"],
              "bin_spacing": f["bin_spacing"] * 200}  # a 200 mm field of view, 0.02 /mm
    np.savez(tmp_path / "mm.npz", **mm)
    run_job(tiny_cfg("method=fbp", "data=file", f"data.path={tmp_path / 'mm.npz'}", *QUIET), run_dir)
    rec = np.load(run_dir / "reconstruction.npz")
    n_bins = mm["sinogram"].shape[1]
    assert float(rec["extent"]) == pytest.approx(n_bins * float(mm["bin_spacing"]))
    assert np.percentile(rec["fbp"], 99) == pytest.approx(0.02, rel=0.15)  # attenuation back in 1/mm


def test_method_failure_is_one_line_exit_1_and_recorded(nct, tmp_path):
    """An expected method failure (here a fit driven to diverge): one line, exit 1, reason in status.json
    (in-process: a process of its own added only its start-up, 7 s)."""
    code, _, err = nct("debug=tiny", "optim.lr=1000", "optim.warmup_steps=0", "logger=none",
                       f"hydra.run.dir={tmp_path}/run")
    assert code == 1, err[-2000:]
    assert err.strip().startswith("nct: error: stage") and "\n" not in err.strip()
    status = read(tmp_path / "run" / "status.json")
    assert status["status"] == "diverged" and status["error"].startswith("DivergenceError")
    assert "traceback" not in status


@pytest.mark.parametrize("cut", ["files removed", "records empty"])
def test_resume_continues_a_killed_run_from_its_last_finished_stage(tiny_cfg, tmp_path, cut):
    """A run killed after its first passes resumes from their checkpoints and ends exactly where
    an uninterrupted run ends; the finished stages are loaded, not run again. A stage whose record a kill
    cut short (nct before records were written whole) runs again."""
    steps = ("optim.refine=true", "optim.refine_init_steps=5", "optim.refine_fit_steps=5", *QUIET)
    whole, killed = tmp_path / "whole", tmp_path / "killed"
    run_job(tiny_cfg(*steps), whole, list(steps))
    shutil.copytree(whole, killed)  # the same run (test_runs_fits_and_is_seeded: a seeded run repeats bit for bit)
    # As if killed during the refinement: its stages unfinished, no metrics, status still running.
    for stage in ("refine_init", "refine_fit"):
        for path in (killed / "checkpoints" / stage).iterdir():
            if cut == "records empty" and path.name == "stage.json":
                path.write_text("")  # created, killed before its write
            else:
                path.unlink()
    (killed / "metrics.json").unlink()
    status = read(killed / "status.json")
    (killed / "status.json").write_text(json.dumps(status | {"status": "running"}))
    run_job(tiny_cfg(*steps, "resume=true"), killed, list(steps))
    stages = read(killed / "metrics.json")["stages"]
    assert stages["free_init"]["resumed"] and stages["free_fit"]["resumed"]
    assert "resumed" not in stages["refine_fit"] and stages["refine_fit"]["steps"] == 5
    np.testing.assert_array_equal(np.load(killed / "reconstruction.npz")["nct"],
                                  np.load(whole / "reconstruction.npz")["nct"])


def test_resume_refuses_a_checkpoint_of_another_model_version(tiny_cfg, tmp_path):
    """A checkpoint written by an older model (here without the frequencies buffer) ends
    the resumed run with one named InputError, not a traceback from load_state_dict."""
    steps = QUIET
    run_job(tiny_cfg(*steps), tmp_path, list(steps))
    ckpt = tmp_path / "checkpoints" / "free_fit" / "last.ckpt"
    saved = torch.load(ckpt, weights_only=True)
    saved["state_dict"] = {k: v for k, v in saved["state_dict"].items() if not k.endswith("omega")}
    torch.save(saved, ckpt)
    (tmp_path / "metrics.json").unlink()
    (tmp_path / "status.json").write_text(json.dumps(read(tmp_path / "status.json") | {"status": "running"}))
    with pytest.raises(InputError, match=r"resume: the checkpoint of stage free_fit .* does not fit this version's model"):
        run_job(tiny_cfg(*steps, "resume=true"), tmp_path, list(steps))


def test_trace_scores_the_field_over_the_run_without_changing_it(tiny_cfg, tmp_path):
    """callbacks.snapshot_every_n_steps keeps the field every n steps of each stage; after the run each
    snapshot is scored against the truth (trace.csv, trace.png, TensorBoard). The last snapshot is
    the result itself, and taking snapshots leaves the reconstruction bit for bit as it was."""
    steps = ("optim.init_steps=6", "optim.fit_steps=5", "export.gif=false", "export.tiff=false")
    run_job(tiny_cfg(*steps, "export.png=false"), tmp_path / "plain")  # its pictures come after the fit, unread
    run_job(tiny_cfg(*steps, "callbacks.snapshot_every_n_steps=2"), tmp_path / "traced")
    np.testing.assert_array_equal(np.load(tmp_path / "traced" / "reconstruction.npz")["nct"],
                                  np.load(tmp_path / "plain" / "reconstruction.npz")["nct"])
    metrics = read(tmp_path / "traced" / "metrics.json")
    trace = metrics["trace"]
    assert [(r["stage"], r["step"]) for r in trace] == [("free_init", s) for s in (0, 2, 4, 6)] + \
        [("free_fit", s) for s in (0, 2, 4, 5)]
    seconds = [r["seconds"] for r in trace]
    assert all(b > a for a, b in zip(seconds, seconds[1:])) and seconds[-1] < metrics["wall_time_s"]
    assert trace[-1]["median_dice"] == pytest.approx(metrics["nct"]["median_dice"], abs=1e-12)
    assert trace[-1]["median_mse"] == pytest.approx(metrics["nct"]["median_mse"], rel=1e-9)
    assert trace[4]["median_dice"] == trace[3]["median_dice"]  # the fit starts from the init's field
    assert trace[0]["median_dice"] < trace[-1]["median_dice"]  # random weights against the fitted field
    rows = (tmp_path / "traced" / "trace.csv").read_text().splitlines()
    assert rows[0] == "stage,step,seconds,median_dice,median_mse" and len(rows) == 1 + len(trace)
    assert (tmp_path / "traced" / "trace.png").is_file() and "trace" not in read(tmp_path / "plain" / "metrics.json")
    acc = EventAccumulator(str(tmp_path / "traced" / "tb"))
    acc.Reload()
    logged = acc.Scalars("trace/median_dice")
    assert [e.step for e in logged] == [round(1000 * t) for t in seconds]
    assert [e.value for e in logged] == pytest.approx([r["median_dice"] for r in trace], abs=1e-6)


def test_trace_ends_with_the_winners_field_whichever_candidate_ran_last(tiny_cfg, tmp_path):
    """motion.rungs [static, free] on the static experiment: static wins within tolerance; the trace's last
    point is the winner's output field (a point of its own where another candidate ran after it)."""
    run_job(tiny_cfg("experiment=static", "motion.rungs=[static,free]", "motion.tolerance=0.5", "optim.init_steps=40",
                     "optim.fit_steps=40", "callbacks.snapshot_every_n_steps=20", "logger=none", "export.gif=false",
                     "export.tiff=false", "export.png=false"), tmp_path)
    metrics = read(tmp_path / "metrics.json")
    assert metrics["model"]["motion"] == "static" and metrics["selection"]["winner"].startswith("static")
    rows = (tmp_path / "selection.csv").read_text().splitlines()
    assert rows[0] == "candidate,n_objects,background,rung,f_max,start,turning,restart,steps,heldout_misfit,verdict" and len(rows) == 1 + len(metrics["selection"]["table"])
    trace = metrics["trace"]
    fitted_last = [r["stage"] for r in trace if r["stage"] != "output"][-1]
    assert trace[-1]["stage"] == ("output" if not fitted_last.startswith("static") else fitted_last)
    assert trace[-1]["median_dice"] == pytest.approx(metrics["nct"]["median_dice"], abs=1e-12)


def test_a_simulation_fits_the_objects_data_n_objects_names(tiny_cfg, monkeypatch):
    """K: data.n_objects when set (the moving parts of a scene inside static anatomy; null: one per
    object of the phantom); the truth keeps every object's own level."""
    conf = validate(tiny_cfg("experiment=static", "data.n_objects=1"))
    scan = acquire(conf, np.random.default_rng(0))
    asked = {}

    def method(*args, n_objects=None, **kwargs):
        asked["n_objects"] = n_objects
        raise RuntimeError("stopped before fitting")

    monkeypatch.setattr("nct.method.reconstruct.reconstruct", method)
    with pytest.raises(RuntimeError, match="stopped before fitting"):
        reconstruct_scan(scan, conf)
    assert asked["n_objects"] == 1 and scan.truth.levels == pytest.approx((0.5, 0.25))
