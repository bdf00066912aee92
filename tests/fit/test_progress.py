"""A run you can watch: without a terminal, a log line every few seconds of a stage and one at its
end; on a terminal, a sized bar."""

from __future__ import annotations

import itertools
import logging
import re
from types import SimpleNamespace

import numpy as np
import pytest
import torch

from nct.acquisition.scanner import ImageGrid, Scanner
from nct.fields.conf import ModelConf
from nct.fit import progress
from nct.fit.conf import CallbacksConf, LossConf, OptimConf, TrainerArgs, TrainerConf
from nct.fit.progress import StageBar, StageLog, show_bar
from nct.init.conf import InitConf
from nct.method.reconstruct import reconstruct
from nct.scenes.phantoms import CircleConf, build_phantom
from nct.scenes.simulate import simulate
from tests.conftest import NO_BACKGROUND

GRID = ImageGrid(32)


PROGRESS = re.compile(r"stage (\w+): step (\d+)/(\d+), loss (\S+), (\d+) s, ETA (\d+) s")
SUMMARY = re.compile(r"stage (\w+): (\d+) steps, loss (\S+), (\S+) s")


def progress_lines(caplog) -> list[str]:
    return [r.getMessage() for r in caplog.records if r.name == "nct.fit.progress"]


def test_progress_lines_are_rate_limited_by_wall_time(caplog):
    """A line once every_s seconds have passed since the last one (or the start), whatever the step."""
    now = [100.0]
    callback = StageLog("fit", every_s=5.0, clock=lambda: now[0])
    trainer = SimpleNamespace(global_step=0, max_steps=40)
    callback.on_train_start(trainer, None)
    with caplog.at_level(logging.INFO, logger="nct.fit.progress"):
        for step, seconds in enumerate([1, 2, 4.9, 5.0, 7, 9.9, 10.1, 30], start=1):  # seconds since the start
            now[0], trainer.global_step = 100.0 + seconds, step
            callback.on_train_batch_end(trainer, None, {"loss": torch.tensor(1.0 / step)}, None, step - 1)
    assert progress_lines(caplog) == ["stage fit: step 4/40, loss 0.25, 5 s, ETA 45 s",  # 5 s / 4 steps x 36 left
                                      "stage fit: step 7/40, loss 0.1429, 10 s, ETA 48 s",
                                      "stage fit: step 8/40, loss 0.125, 30 s, ETA 120 s"]


def test_no_progress_lines_when_set_to_zero(caplog):
    callback = StageLog("init", every_s=0.0, clock=itertools.count(0.0, 100.0).__next__)
    trainer = SimpleNamespace(global_step=1, max_steps=2)
    callback.on_train_start(trainer, None)
    with caplog.at_level(logging.INFO, logger="nct.fit.progress"):
        callback.on_train_batch_end(trainer, None, torch.tensor(1.0), None, 0)
    assert progress_lines(caplog) == []


def test_without_a_bar_stages_log_progress_and_one_line_at_their_end(caplog, monkeypatch):
    """A real fit with a clock that advances 1 s at each reading: progress lines within each stage
    (the steps of each run upwards to its total), then the stage's own line."""
    ticks = itertools.count(0.0, 1.0)
    monkeypatch.setattr(progress, "time", SimpleNamespace(monotonic=lambda: next(ticks)))
    scanner = Scanner(views_per_rotation=60, rotations=1.0, rotation_time=0.25, n_bins=32, bin_spacing=1 / 32)
    times = scanner.frame_times(4)
    sino = simulate(build_phantom(CircleConf(), scanner.rotation_time), scanner, GRID, times, None,
                    np.random.default_rng(0))
    optim = OptimConf(init_steps=4, fit_steps=6, refine=True, refine_init_steps=2, refine_fit_steps=3)
    with caplog.at_level(logging.INFO, logger="nct.fit.progress"):
        result = reconstruct(sino, GRID, times, ModelConf(width=8, depth=1, temporal_width=8, temporal_depth=1,
                                                          n_terms=2), LossConf(),
                             TrainerConf(TrainerArgs(accelerator="cpu"),
                                         CallbacksConf(progress_bar=False, progress_every_s=1.0)), 0,
                             logger="none", optim=optim, init=InitConf(frames_per_rotation=6), background=NO_BACKGROUND,
                             n_objects=1)  # the model given: a fit this small is worse than FBP, and would race another
    # fields this small explain nothing in 6 steps: a restart joins (reconstruct.py's rule)
    planned = {"free_init": 4, "free_fit": 6, "free_restart_init": 4, "free_restart_fit": 6, "refine_init": 2,
               "refine_fit": 3}
    lines = progress_lines(caplog)
    summaries = [SUMMARY.fullmatch(line) for line in lines if SUMMARY.fullmatch(line)]
    assert [m[1] for m in summaries] == list(planned) == list(result.stages)
    for m in summaries:
        record = result.stages[m[1]]
        assert int(m[2]) == record["steps"] == planned[m[1]]
        assert float(m[3]) == pytest.approx(record["losses"]["loss"], rel=1e-3)
        assert float(m[4]) == pytest.approx(record["wall_time_s"], abs=0.05)
    shown = [m for m in map(PROGRESS.fullmatch, lines) if m]
    assert len(shown) + len(summaries) == len(lines)  # nothing else is logged here
    assert {m[1] for m in shown} == set(planned)  # a line each fake second: every step but the last
    for m in shown:
        step, total, elapsed, eta = (int(m[k]) for k in (2, 3, 5, 6))
        assert total == planned[m[1]] and 1 <= step < total and elapsed > 0 and eta > 0
    # each stage's lines, in order: its progress at each step but the last, then its end
    stages = [line.split(":")[0].removeprefix("stage ") for line in lines]
    assert [k for k, _ in itertools.groupby(stages)] == list(planned)
    for stage, total in planned.items():
        mine = [line for line, name in zip(lines, stages) if name == stage]
        steps = [int(PROGRESS.fullmatch(line)[2]) for line in mine[:-1]]
        assert SUMMARY.fullmatch(mine[-1]) and steps == list(range(1, total))


def test_bar_setting_and_size(monkeypatch):
    assert show_bar(True) and not show_bar(False)
    assert show_bar(None) is False  # pytest captures stdout: not a terminal
    monkeypatch.setenv("COLUMNS", "90")
    monkeypatch.setenv("LINES", "30")
    bar = StageBar("fit").init_train_tqdm()
    assert (bar.ncols, bar.nrows, bar.dynamic_ncols) == (90, 30, False)
    bar.close()
