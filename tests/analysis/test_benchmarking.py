"""The benchmark harness: failures counted as failures, speed_accuracy end to end on tiny sizes (real
``nct`` processes, one of them failing) and stability's plan and outputs from hand-made runs."""

import csv
import json
import math
from pathlib import Path

import pytest
from omegaconf import OmegaConf

from nct.analysis.benchmark_stats import seed_stats
from nct.analysis.benchmarking import LOG_FILE, Job, Record, read_run, run_jobs, save_record
from tests.conftest import load_benchmark as load_script

# The scene given (K, no background): a 3-step fit is worse than FBP, and would race another scene model
TINY = ("image.size=32", "image.frames_per_rotation=6", "scanner.views_per_rotation=60", "scanner.n_bins=32",
        "optim.refine=false", "data.n_objects=1", "background=none")




def read_csv(path: Path) -> list[dict]:
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def write_run(run_dir: Path, status: str | None, dice: float = 0.9, log: str = "") -> Path:
    """A hand-made run folder as the pipeline leaves it (``status`` None: the process died first)."""
    run_dir.mkdir(parents=True)
    (run_dir / LOG_FILE).write_text(log)
    if status is not None:
        (run_dir / "status.json").write_text(json.dumps({"status": status, "error": f"{status} error"}))
    if status == "ok":
        summary = {"median_dice": dice, "median_mse": 0.01}
        (run_dir / "metrics.json").write_text(json.dumps(
            {"fbp": summary, "nct": summary, "wall_time_s": 3.0, "model": {"n_params": 1234}}))
    return run_dir


def test_failed_diverged_and_nan_runs_are_failures_scored_zero(tmp_path):
    runs = {"ok": write_run(tmp_path / "ok", "ok", 0.9), "diverged": write_run(tmp_path / "div", "diverged"),
            "nan": write_run(tmp_path / "nan", "ok", math.nan),
            "crash": write_run(tmp_path / "crash", None, log="start\nKilled: out of memory\n")}
    fields = {k: read_run(d, "nct") for k, d in runs.items()}
    assert [fields[k]["status"] for k in runs] == ["ok", "diverged", "invalid", "failed"]
    assert fields["ok"]["dice"] == 0.9 and fields["ok"]["n_params"] == 1234 and fields["ok"]["run_time_s"] == 3.0
    assert fields["crash"]["error"] == "start / Killed: out of memory"
    assert read_run(runs["ok"], "fbp")["n_params"] == 0
    records = [Record(Job({"axis": "noise", "setting": 1e3}, "nct", s, (), d), **fields[k])
               for s, (k, d) in enumerate(runs.items())]
    stats = seed_stats(records)
    assert (stats.n, stats.n_failed, stats.median, stats.max, stats.min) == (4, 3, 0.0, 0.9, 0.0)

    stability = load_script("stability")
    rows = stability.summarise(records + [Record(Job({"axis": "noise", "setting": 1e3}, "fbp", 0, (), tmp_path),
                                                 "ok", dice=0.88)])
    nct = next(r for r in rows if r["method"] == "nct")
    assert (nct["failed"], nct["runs"], nct["dice_median"], nct["dice_q75"]) == (3, 4, 0.0, pytest.approx(0.225))
    axis = stability.Axis("noise", "data.noise_i0", "I0", (1e3,))
    assert {p["method"]: p["breakdown"] for p in stability.breakdowns(rows, [axis])} == {"fbp": None, "nct": 1e3}


def test_job_and_runner_reject_bad_arguments(tmp_path):
    with pytest.raises(ValueError, match="'fbp' or 'nct'"):
        Job({}, "sart", 0, (), tmp_path)
    with pytest.raises(ValueError, match="--jobs"):
        run_jobs([], n_jobs=0)


def test_resume_reuses_finished_records_and_a_rerun_needs_it(tmp_path):
    job = Job({"scene": "s"}, "fbp", 0, ("no.such=key",), write_run(tmp_path / "run", "ok", 0.7))
    with pytest.raises(ValueError, match="--resume"):
        run_jobs([job])
    save_record(Record(job, "ok", dice=0.7, wall_time_s=5.0))
    [record] = run_jobs([job], resume=True, progress=lambda line: None)
    assert (record.status, record.dice, record.wall_time_s) == ("ok", 0.7, 5.0)
    save_record(Record(job, "diverged", error="loss exploded"))
    assert run_jobs([job], resume=True, progress=lambda line: None)[0].error == "loss exploded"


def test_speed_configs_follow_the_configured_steps(tmp_path):
    speed = load_script("speed_accuracy")
    defaults = OmegaConf.create({"optim": {"init_steps": 300, "fit_steps": 800, "refine_init_steps": 200,
                                           "refine_fit_steps": 400, "warmup_steps": 50, "lr_decay_every": 200,
                                           "lr": 1e-3}, "trainer": {"log_every_n_steps": 10}})
    cfgs = {c.name: c for c in speed.configs(defaults, quick=False, paper_steps=100)}
    assert list(cfgs) == ["fbp", "nct-x0.25", "nct-x0.5", "nct-default", "nct-x2", "nct-small", "nct-static",
                          "nct-rigid", "nct-affine", "nct-free", "grid-x0.5", "grid", "grid-auto", "nct-auto",
                          "paper-10steps", "paper-100steps"]
    assert cfgs["grid-auto"].overrides == ("model=grid", "motion=auto")
    assert cfgs["nct-rigid"].overrides == ("motion=rigid",)
    assert cfgs["grid-x0.5"].overrides[:3] == ("model=grid", "optim.init_steps=150", "optim.fit_steps=400")
    assert cfgs["nct-x0.25"].overrides == (
        "optim.init_steps=75", "optim.fit_steps=200", "optim.refine_init_steps=50",
        "optim.refine_fit_steps=100", "optim.warmup_steps=12", "optim.lr_decay_every=50")
    paper = cfgs["paper-100steps"]
    assert paper.overrides == ("model=paper", "optim.refine=true", "optim.init_steps=100", "optim.fit_steps=100",
                               "optim.refine_init_steps=100", "optim.refine_fit_steps=100")
    assert (paper.reference, paper.extrapolate_steps, paper.short, paper.n_seeds) == (True, 5000, "paper-10steps", 1)
    jobs = speed.plan(tmp_path, {"static": ("experiment=static",)}, list(cfgs.values()), [0, 1, 2])
    assert len(jobs) == 14 * 3 + 2 and jobs[0].command()[3:5] == ["experiment=static", "logger=none"]


def speed_records(tmp_path: Path, default_dice: float, paper_dice: float) -> list[Record]:
    """Hand-made circle_100 runs: (config, seed, Dice, run time, stages)."""
    runs = [("nct-default", 0, default_dice, 100.0, {}), ("nct-default", 1, default_dice + 0.02, 110.0, {}),
            ("nct-x0.5", 0, 0.91, 50.0, {}), ("nct-x0.5", 1, 0.93, 52.0, {}),
            ("paper-10steps", 0, 0.5, 60.0, {"fit": {"steps": 10, "wall_time_s": 20.0}}),
            ("paper-100steps", 0, paper_dice, 240.0, {"fit": {"steps": 100, "wall_time_s": 200.0}})]
    return [Record(Job({"scene": "circle_100", "config": c}, "nct", seed, (), tmp_path), "ok", dice=d, mse=0.01,
                   run_time_s=t, stages=st) for c, seed, d, t, st in runs]


def test_headline_compares_our_time_to_target_with_the_paper_sized_model(tmp_path):
    speed = load_script("speed_accuracy")
    cfgs = [speed.Config("nct-default", "nct"), speed.Config("nct-x0.5", "nct"),
            speed.Config("paper-10steps", "nct", reference=True),
            speed.Config("paper-100steps", "nct", reference=True, extrapolate_steps=5000, short="paper-10steps")]
    rows = speed.summarise(speed_records(tmp_path, 0.92, 0.6), cfgs)
    assert rows[3]["time_extrapolated_s"] == pytest.approx(240.0 - 200.0 + 2.0 * 5000)
    assert [r["pareto"] for r in rows] == [True, True, False, False]
    head = speed.headline(rows)
    assert (head["ours_config"], head["ours_time_s"], head["paper_config"]) == ("nct-default", 105.0, "paper-100steps")
    assert head["ratio"] == pytest.approx(10040.0 / 105.0) and head["paper_basis"].startswith("extrapolated")
    head = speed.headline(speed.summarise(speed_records(tmp_path, 0.80, 0.95), cfgs))
    assert (head["ours_config"], head["ours_time_s"], head["paper_time_s"], head["paper_basis"]) == (
        "nct-x0.5", 51.0, 240.0, "measured")


def test_speed_accuracy_runs_a_tiny_benchmark_end_to_end(tmp_path):
    speed = load_script("speed_accuracy")
    cfgs = [speed.Config("fbp", "fbp"),
            speed.Config("paper-tiny", "nct", ("optim.init_steps=3", "optim.fit_steps=3"), reference=True,
                         extrapolate_steps=30),
            speed.Config("broken", "nct", ("optim.lr=-1",))]
    rows = speed.run_benchmark(tmp_path, {"circle_100": speed.SCENES["circle_100"]}, cfgs, [0], n_jobs=2,
                               extra=TINY, command="tiny")
    runs = read_csv(tmp_path / "runs.csv")
    assert [(r["scene"], r["config"], r["method"], r["seed"], r["status"]) for r in runs] == [
        ("circle_100", "fbp", "fbp", "0", "ok"), ("circle_100", "paper-tiny", "nct", "0", "ok"),
        ("circle_100", "broken", "nct", "0", "failed")]
    for r in runs[:2]:
        assert float(r["wall_time_s"]) > float(r["run_time_s"]) > 0
        assert 100 < float(r["peak_mem_mib"]) < 8000
        assert 0 <= float(r["dice_median"]) <= 1 and float(r["mse_median"]) >= 0
        assert r["threads"] == "1"
    assert runs[0]["n_params"] == "0.0" and float(runs[1]["n_params"]) > 100
    assert "optim.lr" in runs[2]["error"] and runs[2]["dice_median"] == "nan"
    fbp, nct, broken = rows
    assert fbp["dice_median"] == pytest.approx(float(runs[0]["dice_median"])) and fbp["pareto"]
    assert nct["time_extrapolated_s"] > nct["run_time_s"]
    assert (broken["failed"], broken["dice_median"], broken["pareto"]) == (1, 0.0, False)
    assert [r["config"] for r in read_csv(tmp_path / "summary.csv")] == ["fbp", "paper-tiny", "broken"]
    for png in ("accuracy_vs_time.png", "params_vs_accuracy.png"):
        assert (tmp_path / png).stat().st_size > 10_000
    note = (tmp_path / "speed_accuracy.md").read_text()
    assert "| circle_100 | fbp | 1/1 |" in note and "| circle_100 | broken | 0/1 | 0.000 " in note
    assert "(extrapolated " in note
    assert "| scene | fbp | paper-tiny | broken |" in note and f"| circle_100 | {fbp['dice_median']:.3f} (" in note


def test_stability_passes_overrides_to_the_neuralct_runs_only(tmp_path, monkeypatch):
    stability = load_script("stability")
    seen = {}
    monkeypatch.setattr(stability, "run_benchmark", lambda out, stress, seeds, nct, *a, **kw: seen.update(nct=nct))
    (tmp_path / "stability.md").write_text("")
    stability.main(["--out", str(tmp_path), "--axis", "displacement", "--override", "motion=auto"])
    assert seen["nct"] == ("motion=auto",)


def test_stability_plans_every_setting_and_maps_failures(tmp_path):
    stability = load_script("stability")
    stress = stability.axes(quick=True, base_displacement=40)
    jobs = stability.plan(tmp_path, stress, [0, 1], nct=("optim.fit_steps=7",))
    assert len(jobs) == 3 * 3 * 2 * 2
    noise = [j for j in jobs if j.labels == {"axis": "noise", "setting": 1e3} and j.method == "nct" and j.seed == 1]
    assert len(noise) == 1 and noise[0].overrides[:4] == (
        "experiment=circle", "phantom.displacement_deg=40", "data.noise_i0=1000.0", "optim.fit_steps=7")
    scores = {("fbp", 720): [0.95, 0.93], ("fbp", 360): [0.9, 0.8], ("nct", 720): [0.97, 0.96],
              ("nct", 360): [0.95, None]}
    axis = stability.Axis("views", "scanner.views_per_rotation", "views", (720, 360))
    records = [Record(Job({"axis": "views", "setting": v}, m, seed, (), tmp_path),
                      "ok" if d is not None else "diverged", dice=d if d is not None else math.nan)
               for (m, v), ds in scores.items() for seed, d in enumerate(ds)]
    rows, points = stability.write_outputs(tmp_path, records, [axis], "cmd", 1.0)
    assert [(r["method"], r["setting"], r["dice_median"], r["failed"]) for r in rows] == [
        ("fbp", 720, pytest.approx(0.94), 0), ("fbp", 360, pytest.approx(0.85), 0),
        ("nct", 720, pytest.approx(0.965), 0), ("nct", 360, pytest.approx(0.475), 1)]
    assert {p["method"]: p["breakdown"] for p in points} == {"fbp": None, "nct": 360}
    assert len(read_csv(tmp_path / "runs.csv")) == 8 and len(read_csv(tmp_path / "breakdown.csv")) == 2
    assert (tmp_path / "stability.png").stat().st_size > 10_000
    note = (tmp_path / "stability.md").read_text()
    assert "| views | none (≥ 0.85 everywhere) | 360 |" in note
    assert "| 360 | 0.850 [0.825–0.875] (0.800–0.900) 0/2 | 0.475 [0.237–0.712] (0.000–0.950) 1/2 |" in note


def test_acceptance_criteria_on_hand_made_scores():
    accept = load_script("acceptance")
    S = accept.Scores
    by = {("circle_100", "nct"): S(0.93, 0.91, 0.004, 0.01, 250.0, 0, 5),
          ("circle_100", "fbp"): S(0.82, 0.82, 0.024, 0.03, 1.0, 0, 5),
          ("heart_cine", "nct"): S(0.99, 0.98, 0.0002, 0.0051, 300.0, 0, 5),
          ("heart_cine", "fbp"): S(0.98, 0.97, 0.002, 0.009, 1.0, 0, 5),
          ("letters", "nct"): S(0.87, 0.80, 0.02, 0.05, 250.0, 0, 5),
          ("letters", "fbp"): S(0.88, 0.88, 0.04, 0.05, 1.0, 0, 5),
          ("static", "nct"): S(0.986, 0.95, 0.0001, 0.0001, 250.0, 1, 5),
          ("static", "fbp"): S(0.997, 0.997, 0.0003, 0.0003, 1.0, 0, 5),
          ("circle_150", "nct"): S(0.905, 0.88, 0.005, 0.02, 250.0, 0, 5),
          ("circle_150", "fbp"): S(0.75, 0.75, 0.03, 0.05, 1.0, 0, 5),
          ("circle_200", "nct"): S(0.845, 0.80, 0.01, 0.03, 250.0, 0, 5),
          ("circle_200", "fbp"): S(0.70, 0.70, 0.04, 0.06, 1.0, 0, 5)}
    rows = accept.criteria(by)
    assert [r["passed"] for r in rows] == [True, True, True,  # circle: Dice, MSE, time
                                           True, False,  # heart_cine: one frame at 0.0051
                                           False,  # letters: above 0.86 but not above FBP
                                           False,  # static: 0.986 < 0.997 - 0.01
                                           True, False]  # fast: 0.905 >= 0.90; 0.845 < 0.85
    assert rows[1]["criterion"] == "NCT MSE < FBP MSE" and rows[1]["measured"] == "0.004 vs 0.024"
    assert accept.criteria({}) == []


def test_acceptance_plans_fbp_360_for_the_circle_only(tmp_path):
    accept = load_script("acceptance")
    jobs = accept.plan(tmp_path, [0, 1])
    labels = {(j.labels["scene"], j.labels["label"]) for j in jobs}
    assert ("circle_100", "fbp360") in labels and ("static", "fbp360") not in labels
    assert len(jobs) == 2 * (6 * 2 + 1)
    assert "fbp.window_deg=360" in jobs[2].overrides + jobs[3].overrides
    candidate = accept.plan(tmp_path, [0], nct=("optim.refine=false",))
    assert all(("optim.refine=false" in j.overrides) == (j.method == "nct") for j in candidate)


def test_a_failed_seed_fails_the_frame_criterion(tmp_path):
    accept = load_script("acceptance")
    job = Job({"scene": "heart_cine", "label": "nct"}, "nct", 0, (), tmp_path / "r")
    s = accept.scores([Record(job=job, status="diverged", error="loss nan")])
    assert s.failed == 1 and s.dice == 0.0 and s.worst_frame_mse == math.inf


def test_a_failed_job_runs_again_in_an_emptied_folder(tmp_path):
    """nct refuses to replace the run a folder holds: a job run again (failed, timed out, killed) gets its folder
    emptied first, and runs (here an FBP-only tiny run) to its own result."""
    folder = write_run(tmp_path / "run", "failed", math.nan)
    (folder / "stale.txt").write_text("from the failed run")
    job = Job({"scene": "s"}, "fbp", 0, ("debug=tiny", "method=fbp", "logger=none", "export.gif=false",
                                          "export.png=false", "export.tiff=false"), folder)
    save_record(Record(job, "failed", error="killed"))
    [record] = run_jobs([job], resume=True, progress=lambda line: None)
    assert record.status == "ok" and not (folder / "stale.txt").exists()
