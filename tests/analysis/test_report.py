"""`nct-report` on hand-made multirun folders: table, plots, summary, and jobs that did not finish."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np
import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from omegaconf import OmegaConf

from nct.analysis.jobs import Job, collect_jobs, flatten_metrics, planned_overrides
from nct.analysis.report import write_report
from nct.analysis.report_figures import (
    aggregate,
    figures,
    heldout_vs_dice_figure,
    tv_grid,
)
from nct.cli.report import main
from tests.conftest import figure_problems

BASIC = "hydra._internal.core_plugins.basic_sweeper.BasicSweeper"


def summary(median_dice: float, median_mse: float) -> dict:
    """A metrics.summarise()-shaped dict."""
    return {"median_mse": median_mse, "iqr_mse": [median_mse / 2, median_mse * 2], "median_nrmse": 0.1,
            "median_psnr": 10 * np.log10(1 / median_mse), "median_ssim": 0.9, "median_dice": median_dice,
            "iqr_dice": [median_dice - 0.05, median_dice + 0.01], "share_mse_lt_0.005": 0.5,
            "share_dice_gt_0.85": 0.75, "per_frame": {"mse": [median_mse] * 3, "dice": [median_dice] * 3}}


def make_sweep(root: Path, params: dict[str, str], task: list[str], sweeper: str = BASIC, **sweeper_extra) -> Path:
    root.mkdir(parents=True)
    hydra = {"sweeper": {"_target_": sweeper, "params": params, **sweeper_extra}, "overrides": {"task": task},
             "mode": "MULTIRUN"}
    OmegaConf.save(OmegaConf.create({"hydra": hydra, "seed": 0}), root / "multirun.yaml")
    return root


def make_job(sweep: Path, num: int, overrides: list[str], status: dict | None, metrics: dict | None = None,
             config: dict | None = None, hydra: dict | None = None) -> Path:
    job = sweep / str(num)
    (job / ".hydra").mkdir(parents=True)
    hydra = {"job": {"num": num}, "mode": "MULTIRUN", **(hydra or {})}
    OmegaConf.save(OmegaConf.create({"hydra": hydra}), job / ".hydra/hydra.yaml")
    OmegaConf.save(OmegaConf.create(overrides), job / ".hydra/overrides.yaml")
    OmegaConf.save(OmegaConf.create(config or {}), job / ".hydra/config.yaml")
    if status is not None:
        (job / "status.json").write_text(json.dumps(status))
    if metrics is not None:
        (job / "metrics.json").write_text(json.dumps(metrics))
    return job


def ok_metrics(nct_dice: float, fbp_dice: float, wall: float) -> dict:
    return {"fbp": summary(fbp_dice, 0.02), "nct": summary(nct_dice, 0.002), "wall_time_s": wall,
            "heldout_loss": 1.0 - nct_dice, "model": {"n_params": 1234}, "selection": {"rung": "rigid"},
            "times": [0.0, 0.1]}


@pytest.fixture
def displacement_sweep(tmp_path: Path) -> Path:
    """displacement {0, 100, 200} x seed {0, 1, 2}: jobs 0-5 ok, 6 failed, 7 unfinished, 8 never started."""
    sweep = make_sweep(tmp_path / "sweep", {"phantom.displacement_deg": "0,100,200", "seed": "0,1,2"},
                       ["sweep=displacement_quick"])
    for num in range(6):
        disp, seed = (0, 100)[num // 3], num % 3
        nct = (0.95 if disp == 0 else 0.80) + 0.01 * seed
        make_job(sweep, num, [f"phantom.displacement_deg={disp}", f"seed={seed}", "sweep=displacement_quick"],
                 {"status": "ok", "error": None, "wall_time_s": 10.0 + num}, ok_metrics(nct, nct - 0.3, 10.0 + num),
                 config={"phantom": {"displacement_deg": 999}, "loss": {"tv_space": 0.5, "tv_time": 0.5}})
    make_job(sweep, 6, ["phantom.displacement_deg=200", "seed=0", "sweep=displacement_quick"],
             {"status": "failed", "error": "RuntimeError: boom\nsecond line", "wall_time_s": 3.0})
    make_job(sweep, 7, ["phantom.displacement_deg=200", "seed=1", "sweep=displacement_quick"], None)
    return sweep


def read_csv(path: Path) -> list[dict[str, str]]:
    with open(path, newline="") as fh:
        return list(csv.DictReader(fh))


def test_report_lists_every_job_with_status_error_and_metrics(displacement_sweep: Path, tmp_path: Path):
    report = write_report(displacement_sweep, tmp_path / "out")
    rows = read_csv(report.csv)
    assert [r["job"] for r in rows] == [str(n) for n in range(9)]
    assert [r["status"] for r in rows] == ["ok"] * 6 + ["failed", "unfinished", "missing"]
    assert rows[6]["error"].startswith("RuntimeError: boom")
    assert "status.json" in rows[7]["error"] and "never started" in rows[8]["error"]
    # the missing job is rebuilt from multirun.yaml with its overrides
    assert (rows[8]["phantom.displacement_deg"], rows[8]["seed"], rows[8]["sweep"]) == ("200", "2", "displacement_quick")
    assert float(rows[4]["nct.median_dice"]) == pytest.approx(0.81)
    assert float(rows[4]["fbp.median_dice"]) == pytest.approx(0.51)
    assert float(rows[4]["nct.iqr_dice_q25"]) == pytest.approx(0.76)
    assert float(rows[4]["heldout_loss"]) == pytest.approx(0.19)
    assert float(rows[4]["model.n_params"]) == 1234 and rows[4]["selection.rung"] == "rigid"
    assert float(rows[6]["wall_time_s"]) == 3.0 and rows[6]["nct.median_dice"] == ""
    assert not any(k.startswith("nct.per_frame") or k == "times" for k in rows[0])
    assert set(report.plots) == {"displacement", "accuracy_vs_time", "heldout_vs_dice"}
    assert all(p.is_file() and p.stat().st_size > 5000 for p in report.plots.values())


def test_aggregate_over_seeds_uses_overrides_over_config(displacement_sweep: Path):
    jobs = collect_jobs(displacement_sweep)
    agg = aggregate(jobs, "phantom.displacement_deg", "nct.median_dice")
    np.testing.assert_allclose(agg.x, [0, 100])  # not the config's 999: the override wins
    np.testing.assert_array_equal(agg.n, [3, 3])
    np.testing.assert_allclose(agg.mean, [0.96, 0.81])
    np.testing.assert_allclose(agg.sd, [0.01, 0.01])


def test_summary_lists_failed_unfinished_and_missing(displacement_sweep: Path):
    text = write_report(displacement_sweep).summary.read_text()
    assert "9 jobs: 1 failed, 1 missing, 6 ok, 1 unfinished." in text
    assert "| 0 | 3 | 0.66 ± 0.01 | 0.96 ± 0.01 |" in text
    assert ("| job | phantom.displacement_deg | seed | status | FBP Dice | NCT Dice | FBP MSE | NCT MSE | FBP PSNR dB "
            "| NCT PSNR dB | FBP SSIM | NCT SSIM | held-out loss | rung chosen | wall s |") in text
    assert "| 0 | 0 | 0 | ok | 0.65 | 0.95 | 0.02 | 0.002 | 17 | 27 | 0.9 | 0.9 | 0.05 | rigid | 10 |" in text
    assert "- job 6 (phantom.displacement_deg=200 seed=0): **failed**: RuntimeError: boom" in text
    assert "second line" not in text
    assert "- job 7 (phantom.displacement_deg=200 seed=1): **unfinished**" in text
    assert "- job 8 (phantom.displacement_deg=200 seed=2): **missing**" in text
    # every job has its own data (displacement and seed): no truth-free choice across scenes
    assert "Truth-free choice: none to make (no two settings ran on the same scene" in text
    assert "![displacement](displacement.png)" in text
    assert f"    nct -m sweep=displacement_quick hydra.sweep.dir={displacement_sweep} resume=true" in text
    assert (displacement_sweep / "report" / "report.csv").is_file()


def test_summary_says_where_each_jobs_time_went(displacement_sweep: Path):
    """metrics.json ``phases`` per job, the tournament split into its stages' fits and selection; jobs from
    before the phases were recorded are left out of that table, not shown as zeros."""
    assert "## Where the time went" not in write_report(displacement_sweep).summary.read_text()
    for num, startup in ((1, 4.0), (2, 6.0)):
        path = displacement_sweep / str(num) / "metrics.json"
        phases = {"wall_s": {"startup": startup, "data": 0.5, "tournament": 9.0, "exports": 0.5},
                  "cpu_s": {"startup": 3.0, "data": 0.4, "tournament": 8.0, "exports": 0.4}}
        stages = {"free_init": {"wall_time_s": 2.0}, "free_fit": {"wall_time_s": 6.5}}
        path.write_text(json.dumps(json.loads(path.read_text()) | {"phases": phases, "stages": stages}))
    text = write_report(displacement_sweep).summary.read_text()
    assert "## Where the time went (wall s per phase" in text
    assert "| job | phantom.displacement_deg | seed | startup | data | fits | selection | exports | wall s |" in text
    assert "| 1 | 0 | 1 | 4 | 0.5 | 8.5 | 0.5 | 0.5 | 11 |\n| 2 | 0 | 2 | 6 | 0.5 | 8.5 | 0.5 | 0.5 | 12 |\n\n" in text


def test_summary_lists_the_warnings_of_suspect_fits(displacement_sweep: Path):
    assert "## Warnings\n\nNone: no run warned." in write_report(displacement_sweep).summary.read_text()
    status = displacement_sweep / "4" / "status.json"
    status.write_text(json.dumps(json.loads(status.read_text()) | {"warnings": ["suspect fit: its held-out misfit"]}))
    text = write_report(displacement_sweep).summary.read_text()
    assert "## Warnings\n\n- job 4 (phantom.displacement_deg=100 seed=1): suspect fit: its held-out misfit\n" in text


def test_tv_grid_heat_map(tmp_path: Path):
    sweep = make_sweep(tmp_path / "tv", {"loss.tv_space": "0,1", "loss.tv_time": "0,1"}, [])
    for num, (s, t) in enumerate([(0, 0), (0, 1), (1, 0), (1, 1)]):
        if num == 3:
            make_job(sweep, num, [f"loss.tv_space={s}", f"loss.tv_time={t}"],
                     {"status": "diverged", "error": "DivergenceError: loss is nan", "wall_time_s": 1.0})
            continue
        make_job(sweep, num, [f"loss.tv_space={s}", f"loss.tv_time={t}"],
                 {"status": "ok", "error": None, "wall_time_s": 5.0}, ok_metrics(0.5 + 0.1 * num, 0.4, 5.0))
    report = write_report(sweep)
    spaces, times, grid, counts = tv_grid(report.jobs)
    assert spaces == [0.0, 1.0] and times == [0.0, 1.0]
    np.testing.assert_allclose(grid, [[0.5, 0.6], [0.7, np.nan]])
    np.testing.assert_array_equal(counts, [[1, 1], [1, 0]])
    assert figures(report.jobs)["tv_grid"].axes[0].get_title() == "NCT median Dice: one job per setting"
    assert "## NCT median Dice on the TV grid (one job per setting; rows: TV space" in report.summary.read_text()
    assert "tv_grid" in report.plots and "displacement" not in report.plots and "f_max" not in report.plots
    assert "**diverged**: DivergenceError: loss is nan" in report.summary.read_text()
    # one scene, three finished settings: held-out loss 1 - Dice picks job 2, the best Dice too
    assert ("- 3 settings of one scene: the truth-free score picks job 2 (loss.tv_space=1 loss.tv_time=0), "
            "NCT median Dice 0.7; the best Dice is job 2 (loss.tv_space=1 loss.tv_time=0)'s 0.7: 0 lost."
            ) in report.summary.read_text()


def test_truth_free_choice_is_per_scene_and_says_what_it_loses(tmp_path: Path):
    """Two scenes (displacements) of two F_max each; at 150 deg the held-out loss prefers the worse job."""
    sweep = make_sweep(tmp_path / "f", {"model.f_max": "0.3,3", "phantom.displacement_deg": "100,150"}, [])
    cases = [(0.3, 100, 0.95, 0.04), (3, 100, 0.83, 0.05), (0.3, 150, 0.94, 0.05), (3, 150, 0.82, 0.04)]
    for num, (f, deg, dice, held) in enumerate(cases):
        make_job(sweep, num, [f"model.f_max={f}", f"phantom.displacement_deg={deg}"],
                 {"status": "ok", "error": None, "wall_time_s": 1.0}, ok_metrics(dice, 0.8, 1.0) | {"heldout_loss": held})
    text = write_report(sweep).summary.read_text()
    assert ("- 2 settings of one scene: the truth-free score picks job 0 (model.f_max=0.3 phantom.displacement_deg=100), "
            "NCT median Dice 0.95; the best Dice is job 0 (model.f_max=0.3 phantom.displacement_deg=100)'s 0.95: 0 lost."
            ) in text
    assert ("- 2 settings of one scene: the truth-free score picks job 3 (model.f_max=3 phantom.displacement_deg=150), "
            "NCT median Dice 0.82; the best Dice is job 2 (model.f_max=0.3 phantom.displacement_deg=150)'s 0.94: "
            "0.12 lost.") in text


def test_truth_free_choice_pools_seeds_as_replicates(tmp_path: Path):
    """Over seeds 0-2, F_max 3's mean held-out loss is the lowest (0.035 against 0.038), but it
    spreads over seeds (standard error 0.004): F_max 0.3 is within that error and simpler. Seed 0
    alone, with its run's own error (0.0005), picks F_max 3. A setting missing a seed is left out."""
    cases = [(0.3, [0.036, 0.040, 0.038], [0.95, 0.94, 0.96]), (3, [0.028, 0.042, 0.035], [0.83, 0.82, 0.84]),
             (1, [0.020, 0.020], [0.5, 0.5])]
    for seeds, picked in (("0,1,2", "jobs 0 1 2 (model.f_max=0.3), NCT median Dice 0.95"),
                          ("0", "job 3 (model.f_max=3), NCT median Dice 0.83")):
        sweep = make_sweep(tmp_path / f"s{len(seeds)}", {"model.f_max": "0.3,3,1", "seed": seeds}, [])
        num = 0
        for f, losses, dices in cases:
            for seed, (held, dice) in enumerate(zip(losses, dices)):
                if str(seed) in seeds.split(",") and not (f == 1 and seeds == "0"):
                    make_job(sweep, num, [f"model.f_max={f}", f"seed={seed}"],
                             {"status": "ok", "error": None, "wall_time_s": 1.0},
                             ok_metrics(dice, 0.8, 1.0) | {"heldout_loss": held, "heldout_se": 0.0005})
                num += 1
        text = write_report(sweep).summary.read_text()
        n_seeds = ", 3 seeds each" if seeds == "0,1,2" else ""
        assert f"- 2 settings of one scene{n_seeds}: the truth-free score picks {picked}; " in text


def test_truth_free_choice_takes_the_simplest_within_one_standard_error(tmp_path: Path):
    """F_max 3 has the lowest held-out loss; F_max 0.3 is within its standard error (0.002), F_max 0
    is not: the rule picks F_max 0.3. With a standard error of 0.0005 it keeps F_max 3."""
    for se, picked, dice in ((0.002, "job 1 (model.f_max=0.3)", "0.95"), (0.0005, "job 2 (model.f_max=3)", "0.83")):
        sweep = make_sweep(tmp_path / f"se{se}", {"model.f_max": "0,0.3,3"}, [])
        for num, (f, d, held) in enumerate([(0, 0.6, 0.3), (0.3, 0.95, 0.0335), (3, 0.83, 0.0320)]):
            make_job(sweep, num, [f"model.f_max={f}"], {"status": "ok", "error": None, "wall_time_s": 1.0},
                     ok_metrics(d, 0.8, 1.0) | {"heldout_loss": held, "heldout_se": se})
        text = write_report(sweep).summary.read_text()
        assert f"the truth-free score picks {picked}, NCT median Dice {dice}; the best Dice is job 1 (model.f_max=0.3)'s 0.95" in text


def test_optuna_sweep_counts_missing_trials_from_its_jobs(tmp_path: Path):
    sweep = tmp_path / "optuna"  # the Optuna sweeper writes no multirun.yaml
    optuna = {"sweeper": {"_target_": "hydra_plugins.hydra_optuna_sweeper.optuna_sweeper.OptunaSweeper",
                          "n_trials": 3}}
    for num, f_max in enumerate((1.5, 6.0)):
        make_job(sweep, num, [f"model.f_max={f_max}"], {"status": "ok", "error": None, "wall_time_s": 2.0},
                 ok_metrics(0.9 - 0.1 * num, 0.5, 2.0), hydra=optuna)
    report = write_report(sweep)
    assert [(j.num, j.status) for j in report.jobs] == [(0, "ok"), (1, "ok"), (2, "missing")]
    assert "f_max" in report.plots


def test_planned_overrides_follow_hydra_basic_sweeper_order():
    jobs = planned_overrides({"a": "1,2"}, ["b=x,y", "c=3", "+d=4"])
    assert jobs == [{"a": "1", "b": "x", "c": "3", "d": "4"}, {"a": "1", "b": "y", "c": "3", "d": "4"},
                    {"a": "2", "b": "x", "c": "3", "d": "4"}, {"a": "2", "b": "y", "c": "3", "d": "4"}]


def test_flatten_metrics_keeps_scalars_and_iqr():
    flat = flatten_metrics({"nct": summary(0.9, 0.001), "heldout_loss": 0.1, "stages": {"fit": {"steps": 5}},
                            "times": [0.0, 1.0], "ok": True})
    assert flat["nct.iqr_mse_q75"] == pytest.approx(0.002)
    assert flat["stages.fit.steps"] == 5 and flat["ok"] == 1.0 and flat["heldout_loss"] == 0.1
    assert "times" not in flat and not any("per_frame" in k for k in flat)


def test_job_metric_is_nan_when_absent():
    assert np.isnan(Job(0, {}, "failed").metric("nct.median_dice"))


@pytest.mark.parametrize("layout", ["missing", "empty", "single_run", "folder_of_runs", "folder_of_sweeps", "file"])
def test_bad_dir_is_one_line_error_exit_2(tmp_path: Path, capsys, layout: str):
    target = tmp_path / "d"
    if layout == "empty":
        target.mkdir()
    elif layout == "single_run":
        (target / ".hydra").mkdir(parents=True)
    elif layout == "folder_of_runs":  # e.g. outputs/runs: single runs side by side
        make_job(target, 0, [], {"status": "ok", "error": None, "wall_time_s": 1.0}, hydra={"mode": "RUN"})
    elif layout == "folder_of_sweeps":  # e.g. outputs/multirun
        make_sweep(target / "a", {"seed": "0,1"}, [])
        make_job(target / "a", 0, ["seed=0"], {"status": "ok", "error": None, "wall_time_s": 1.0})
    elif layout == "file":
        target.write_text("x")
    assert main([str(target)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("nct-report: error:") and len(err.splitlines()) == 1 and str(target) in err


def test_main_writes_to_out(displacement_sweep: Path, tmp_path: Path, capsys):
    assert main([str(displacement_sweep), "--out", str(tmp_path / "o")]) == 0
    assert (tmp_path / "o" / "report.csv").is_file() and (tmp_path / "o" / "summary.md").is_file()
    assert "9 jobs (3 not ok)" in capsys.readouterr().out


def sweep_with_seeds(root: Path, n_seeds: int) -> Path:
    """displacement {0, 100} x ``n_seeds`` seeds, all ok."""
    sweep = make_sweep(root, {"phantom.displacement_deg": "0,100", "seed": ",".join(map(str, range(n_seeds)))}, [])
    for num in range(2 * n_seeds):
        disp, seed = (0, 100)[num // n_seeds], num % n_seeds
        nct = 0.9 - disp / 1000 + 0.01 * seed
        make_job(sweep, num, [f"phantom.displacement_deg={disp}", f"seed={seed}"],
                 {"status": "ok", "error": None, "wall_time_s": 5.0}, ok_metrics(nct, nct - 0.3, 5.0))
    return sweep


@pytest.mark.parametrize(("n_seeds", "shown"), [(1, "one job per setting"),
                                                (3, "mean ± sd over 3 jobs per setting")])
def test_legends_and_summary_say_what_is_shown(tmp_path: Path, n_seeds: int, shown: str):
    """One seed: each point is one job, with no spread to speak of; several: their mean ± sd."""
    jobs = collect_jobs(sweep_with_seeds(tmp_path / "s", n_seeds))
    fig = figures(jobs)["displacement"]
    assert [legend.get_title().get_text() for legend in fig.legends] == [shown]
    text = write_report(tmp_path / "s").summary.read_text()
    assert f"## By displacement (each job's median; {shown})" in text
    assert ("±" in text) == (n_seeds > 1)
    assert np.isnan(aggregate(jobs, "phantom.displacement_deg", "nct.median_dice").sd).all() == (n_seeds == 1)


#: What each report figure's labels must name: its units (MSE in the data's intensity unit squared).
FIGURE_UNITS = {"displacement": ("(deg)", "intensity unit²"), "f_max": ("cycles/rotation", "intensity unit²"),
                "tv_grid": (), "accuracy_vs_time": ("(s)",), "heldout_vs_dice": ("unitless",)}


def test_every_report_figure_explains_itself(tmp_path: Path, displacement_sweep: Path):
    """Title, labels with units, a colourbar or a legend that covers no point, on every plot the
    report draws (a displacement sweep with failures, an F_max x displacement sweep, a TV grid)."""
    grid = make_sweep(tmp_path / "tv", {"loss.tv_space": "0,1", "loss.tv_time": "0,1"}, [])
    mixed = make_sweep(tmp_path / "f", {"model.f_max": "0.3,3", "phantom.displacement_deg": "100,150"}, [])
    for num, (a, b) in enumerate([(0, 0), (0, 1), (1, 0), (1, 1)]):
        make_job(grid, num, [f"loss.tv_space={a}", f"loss.tv_time={b}"],
                 {"status": "ok", "error": None, "wall_time_s": 5.0 + num}, ok_metrics(0.5 + 0.1 * num, 0.4, 5.0))
        make_job(mixed, num, [f"model.f_max={(0.3, 3)[a]}", f"phantom.displacement_deg={(100, 150)[b]}"],
                 {"status": "ok", "error": None, "wall_time_s": 5.0 + num}, ok_metrics(0.9 - 0.1 * num, 0.7, 5.0))
    drawn = {}
    for sweep in (displacement_sweep, grid, mixed):
        for name, fig in figures(collect_jobs(sweep)).items():
            drawn[name] = name
            assert figure_problems(fig, FIGURE_UNITS[name]) == [], (sweep.name, name)
    assert sorted(drawn) == sorted(FIGURE_UNITS)


def overlapping_tick_labels(fig: Figure) -> list[tuple[str, str]]:
    """Pairs of neighbouring visible tick labels on any axis of ``fig`` whose drawn boxes overlap."""
    fig.canvas = FigureCanvasAgg(fig)
    renderer = fig.canvas.get_renderer()
    fig.draw(renderer)
    pairs = []
    for ax in fig.axes:
        for axis in (ax.xaxis, ax.yaxis):
            labels = [t for t in axis.get_ticklabels(minor=False) + axis.get_ticklabels(minor=True)
                      if t.get_visible() and t.get_text()]
            boxes = sorted(((t.get_window_extent(renderer), t.get_text()) for t in labels),
                           key=lambda b: (b[0].x0, b[0].y0))
            pairs += [(a[1], b[1]) for a, b in zip(boxes, boxes[1:]) if a[0].overlaps(b[0])]
    return pairs


@pytest.mark.parametrize("span", [1.27, 16, 150, 1e6])
def test_heldout_vs_dice_tick_labels_do_not_overlap(span: float):
    """Held-out losses over a narrow range (a fifth of a decade) up to six decades."""
    losses = np.geomspace(1.1e-3, 1.1e-3 * span, 9)
    jobs = [Job(i, {}, "ok", metrics={"heldout_loss": x, "nct.median_dice": 0.9 - 0.01 * i})
            for i, x in enumerate(losses)]
    fig = heldout_vs_dice_figure(jobs)
    assert overlapping_tick_labels(fig) == []
    assert fig.axes[0].get_xscale() == ("log" if span >= 100 else "linear")
    assert len([t for t in fig.axes[0].get_xticklabels() if t.get_text()]) >= 2


def test_help_is_plain_text(capsys):
    with pytest.raises(SystemExit) as exit_info:
        main(["--help"])
    assert exit_info.value.code == 0
    text = capsys.readouterr().out
    assert "`" not in text and "**" not in text and ":func:" not in text
    assert "report.csv" in text and "summary.md" in text and "--out" in text
