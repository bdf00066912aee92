"""A run you can watch: one log line per stage when stdout is not a terminal, a sized bar otherwise."""

from __future__ import annotations

import logging
import re

import numpy as np
import pytest

from nct.acquisition.scanner import ImageGrid, Scanner
from nct.method.conf import InitConf, LossConf, OptimConf, TrainerConf
from nct.method.fields import ModelConf
from nct.method.progress import StageBar, show_bar
from nct.method.reconstruct import reconstruct
from nct.scenes.phantoms import CircleConf, build_phantom
from nct.scenes.simulate import simulate

GRID = ImageGrid(32)


def test_without_a_bar_each_stage_logs_one_line(caplog):
    scanner = Scanner(views_per_rotation=60, rotations=1.0, rotation_time=0.25, n_bins=32, bin_spacing=1 / 32)
    times = scanner.frame_times(4)
    sino = simulate(build_phantom(CircleConf(), scanner.rotation_time), scanner, GRID, times, None,
                    np.random.default_rng(0))
    optim = OptimConf(init_steps=4, fit_steps=6, refine=True, refine_init_steps=2, refine_fit_steps=3)
    with caplog.at_level(logging.INFO, logger="nct.method.progress"):
        result = reconstruct(sino, GRID, times, ModelConf(width=8, depth=1, temporal_width=8, temporal_depth=1,
                                                          n_terms=2), LossConf(),
                             TrainerConf(accelerator="cpu", progress_bar=False), 0, logger="none", optim=optim,
                             init=InitConf(frames_per_rotation=6))
    lines = [r.getMessage() for r in caplog.records if r.name == "nct.method.progress"]
    assert [line.split(":")[0] for line in lines] == [f"stage {s}" for s in ("init", "fit", "refine_init", "refine_fit")]
    for line, (stage, record) in zip(lines, result.stages.items()):
        steps, loss, seconds = re.fullmatch(r"stage \w+: (\d+) steps, loss (\S+), (\S+) s", line).groups()
        assert int(steps) == record["steps"] == {"init": 4, "fit": 6, "refine_init": 2, "refine_fit": 3}[stage]
        assert float(loss) == pytest.approx(record["losses"]["loss"], rel=1e-3)
        assert float(seconds) == pytest.approx(record["wall_time_s"], abs=0.05)


def test_bar_setting_and_size(monkeypatch):
    assert show_bar(True) and not show_bar(False)
    assert show_bar(None) is False  # pytest captures stdout: not a terminal
    monkeypatch.setenv("COLUMNS", "90")
    monkeypatch.setenv("LINES", "30")
    bar = StageBar("fit").init_train_tqdm()
    assert (bar.ncols, bar.nrows, bar.dynamic_ncols) == (90, 30, False)
    bar.close()
