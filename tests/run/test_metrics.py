"""Per-frame MSE and Dice, and the per-run summary."""

import numpy as np
import pytest

from nct.run.metrics import FrameMetrics, dice, frame_metrics, summarise


def test_dice_known_values():
    a = np.zeros((4, 4), bool)
    b = np.zeros((4, 4), bool)
    a[:2] = True  # 8 pixels
    b[1:3] = True  # 8 pixels, 4 shared
    assert dice(a, b) == pytest.approx(0.5)
    assert dice(a, a) == pytest.approx(1.0)
    assert dice(np.zeros_like(a), np.zeros_like(a)) == pytest.approx(1.0)


def test_frame_metrics_threshold_and_mse():
    truth = np.zeros((2, 4, 4), np.float32)
    truth[:, :2] = 1.0
    recon = truth.copy()
    recon[1, :2, :2] = 0.4  # below the level: 4 of 8 pixels lost in frame 1
    m = frame_metrics(recon, truth, level=0.5)
    assert m.dice[0] == pytest.approx(1.0)
    assert m.dice[1] == pytest.approx(2 * 4 / (4 + 8))
    assert m.mse[1] == pytest.approx(4 * 0.36 / 16)
    with pytest.raises(ValueError, match="shape"):
        frame_metrics(recon[:1], truth, 0.5)


def test_summary():
    m = FrameMetrics(mse=np.array([0.001, 0.002, 0.01, 0.02]), dice=np.array([0.5, 0.9, 0.95, 0.99]))
    s = summarise(m)
    assert s["median_mse"] == pytest.approx(0.006)
    assert s["median_dice"] == pytest.approx(0.925)
    assert s["share_mse_lt_0.005"] == pytest.approx(0.5)
    assert s["share_dice_gt_0.85"] == pytest.approx(0.75)
    assert s["iqr_dice"][0] < s["median_dice"] < s["iqr_dice"][1]
    assert len(s["per_frame"]["dice"]) == 4
