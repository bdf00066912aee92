"""benchmarks/levels.py: the brightest-level ratio, and its report on a call's runs."""

from __future__ import annotations

import numpy as np
import pytest

from test_generalisation import load


def _disc(radius: float, level: float, size: int = 32) -> np.ndarray:
    y, x = np.mgrid[:size, :size] - (size - 1) / 2
    return np.where(np.hypot(x, y) <= radius, level, 0.0)[None].astype(np.float32)


def test_brightest_ratio_sees_a_disc_drawn_wider_and_fainter():
    levels = load("levels")
    truth = _disc(3, 2.0)
    assert levels.brightest_ratio(truth, truth) == pytest.approx(1.0)
    # Twice as wide at half the level: about the same mass, but the true disc's pixels read 1.0.
    assert levels.brightest_ratio(truth, _disc(6, 1.0)) == pytest.approx(0.5)
    assert levels.brightest_ratio(truth, 0.9 * truth) == pytest.approx(0.9)
    with pytest.raises(ValueError, match="differ in shape"):
        levels.brightest_ratio(truth, truth[:, :-1])


def _run(call, scene: str, truth: np.ndarray, nct: np.ndarray, fbp: np.ndarray) -> None:
    folder = call / "runs" / scene / "nct"
    folder.mkdir(parents=True)
    np.savez(folder / "reconstruction.npz", nct=nct, fbp=fbp)
    np.savez(folder / "sinogram.npz", truth=truth)


def test_levels_report_lists_the_scenes_where_nct_is_fainter_than_fbp(tmp_path, capsys):
    levels = load("levels")
    call = tmp_path / "call"
    truth = _disc(3, 2.0)
    _run(call, "scene000", truth, _disc(6, 1.0), 0.95 * truth)   # NCT 0.5, FBP 0.95: listed
    _run(call, "scene001", truth, truth, 0.8 * truth)            # NCT 1.0, FBP 0.8: not listed
    (call / "scenes.csv").write_text("scene,layout,radii_pct,nct_status\nscene000,nested,30x20 5x5,ok\n"
                                     "scene001,apart,10x10 4x4,ok\nscene002,single,5x5,failed\n")
    assert levels.main(["--call", str(call), "--out", str(tmp_path / "levels.md")]) == 0
    out = capsys.readouterr().out
    assert "2 scenes" in out and "median NCT 0.750, FBP 0.875" in out and "below 0.9: NCT 1, FBP 1" in out
    assert "| scene000 | nested | 30x20 5x5 | 0.500 | 0.950 |" in out and "| scene001 |" not in out
    assert (tmp_path / "levels.md").read_text() == out.rstrip("\n") + "\n"


def test_levels_report_says_when_there_is_nothing_to_read(tmp_path, capsys):
    levels = load("levels")
    assert levels.main(["--call", str(tmp_path)]) == 1
    assert "levels: error: no scenes.csv" in capsys.readouterr().err
