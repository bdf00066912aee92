"""Per-frame MSE, NRMSE, PSNR, SSIM and Dice (of the foreground and at each object's own level), and
the per-run summary."""

import numpy as np
import pytest

from nct.run.metrics import (
    FrameMetrics,
    dice,
    frame_metrics,
    mse_bar,
    quality_line,
    summarise,
)


def test_dice_known_values():
    a = np.zeros((4, 4), bool)
    b = np.zeros((4, 4), bool)
    a[:2] = True  # 8 pixels
    b[1:3] = True  # 8 pixels, 4 shared
    assert dice(a, b) == pytest.approx(0.5)
    assert dice(a, a) == pytest.approx(1.0)
    assert dice(np.zeros_like(a), np.zeros_like(a)) == pytest.approx(1.0)


def test_frame_metrics_threshold_and_errors():
    truth = np.zeros((2, 4, 4), np.float32)
    truth[:, :2] = 1.0
    recon = truth.copy()
    recon[1, :2, :2] = 0.4  # below the level: 4 of 8 pixels lost in frame 1
    m = frame_metrics(recon, truth, level=0.5)
    assert m.dice[0] == pytest.approx(1.0)
    assert m.dice[1] == pytest.approx(2 * 4 / (4 + 8))
    assert m.mse[1] == pytest.approx(4 * 0.36 / 16)
    assert m.psnr[1] == pytest.approx(10 * np.log10(1.0 / m.mse[1]))  # over the truth's range, 1
    assert m.nrmse[1] == pytest.approx(np.sqrt(4 * 0.36 / 8))  # ||error|| / ||truth||
    assert m.ssim[0] == pytest.approx(1.0) and m.ssim[1] < 1.0
    assert m.psnr[0] == np.inf and m.nrmse[0] == 0.0
    with pytest.raises(ValueError, match="shape"):
        frame_metrics(recon[:1], truth, 0.5)


def test_relative_scores_and_the_good_frame_bar_do_not_depend_on_the_unit():
    """The same scene in 1/mm (intensity 0.02): MSE scales by 0.02², NRMSE, PSNR, SSIM and the share
    of good frames do not; a fixed bar of 0.005 would call every frame of it good."""
    rng = np.random.default_rng(0)
    truth = np.zeros((6, 24, 24))
    truth[:, 6:18, 6:18] = 1.0
    recon = truth + rng.normal(0, [[[0.03]], [[0.03]], [[0.05]], [[0.1]], [[0.1]], [[0.2]]], truth.shape)
    unit, mm = frame_metrics(recon, truth, 0.5), frame_metrics(0.02 * recon, 0.02 * truth, 0.01)
    assert mm.mse == pytest.approx(0.02**2 * unit.mse)
    for field in ("nrmse", "psnr", "ssim", "dice"):
        assert getattr(mm, field) == pytest.approx(getattr(unit, field)), field
    assert unit.mse_good_below == pytest.approx(0.005) and mm.mse_good_below == pytest.approx(0.005 * 0.02**2)
    assert summarise(mm)["share_mse_lt_0.005"] == summarise(unit)["share_mse_lt_0.005"] == pytest.approx(3 / 6)
    assert np.mean(mm.mse < 0.005) == 1.0


def summary_of(mse: list[float], dice_: list[float]) -> dict:
    n = len(mse)
    return summarise(FrameMetrics(mse=np.array(mse), nrmse=np.full(n, 0.1), psnr=np.full(n, 30.0),
                                  ssim=np.full(n, 0.9), dice=np.array(dice_), data_range=1.0,
                                  mse_good_below=mse_bar(1.0)))


def test_summary():
    s = summary_of([0.001, 0.002, 0.01, 0.02], [0.5, 0.9, 0.95, 0.99])
    assert s["median_mse"] == pytest.approx(0.006)
    assert s["median_dice"] == pytest.approx(0.925)
    assert s["share_mse_lt_0.005"] == pytest.approx(0.5)
    assert s["share_dice_gt_0.85"] == pytest.approx(0.75)
    assert (s["median_nrmse"], s["median_psnr"], s["median_ssim"]) == pytest.approx((0.1, 30.0, 0.9))
    assert s["iqr_dice"][0] < s["median_dice"] < s["iqr_dice"][1]
    assert len(s["per_frame"]["dice"]) == 4 and len(s["per_frame"]["psnr"]) == 4


def test_quality_line_has_significant_digits_for_small_errors():
    line = quality_line(summary_of([3.1234e-6] * 3, [0.97] * 3))
    assert "MSE 3.12e-06 (intensity unit²)" in line and "PSNR 30 dB" in line and "0.00000" not in line


def test_dice_at_each_object_own_level():
    """A small bright object inside a dim body: at the body's level the body, at the object's own
    level (the body's plus half its own) the object alone, which the foreground's Dice hides."""
    truth = np.zeros((2, 16, 16))
    truth[:, 2:14, 2:14] = 0.4
    truth[:, 6:8, 6:8] = 1.4  # 4 pixels
    recon = truth.copy()
    recon[1, 6:8, 6:8] = 0.4  # frame 1 loses the object
    recon[1, 6:8, 8:10] = 1.4  # ... and draws it beside itself
    m = frame_metrics(recon, truth, 0.2, object_levels=(0.2, 0.9))
    assert m.object_levels == (0.2, 0.9) and m.object_dice.shape == (2, 2)
    assert m.object_dice[0] == pytest.approx([1.0, 1.0]) and m.object_dice[1] == pytest.approx([1.0, 0.0])
    assert m.dice == pytest.approx([1.0, 1.0])
    s = summarise(m)
    assert s["objects"] == [{"level": 0.2, "median_dice": 1.0}, {"level": 0.9, "median_dice": 0.5}]
    assert s["per_frame"]["object_dice"] == [[1.0, 1.0], [1.0, 0.0]]
    assert "at the objects' own levels 0.2: Dice 1, 0.9: Dice 0.5" in quality_line(s)
    assert summarise(frame_metrics(recon, truth, 0.2))["objects"] == []
