"""Per-frame image quality (MSE, foreground Dice) and their per-run summary."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

MSE_GOOD = 0.005
DICE_GOOD = 0.85


@dataclass(frozen=True)
class FrameMetrics:
    """mse, dice: [F] float64, one value per frame."""

    mse: np.ndarray
    dice: np.ndarray


def dice(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Dice of boolean masks over the last two axes: [..., H, W] -> [...]; two empty masks score 1."""
    inter = np.logical_and(a, b).sum(axis=(-2, -1))
    total = a.sum(axis=(-2, -1)) + b.sum(axis=(-2, -1))
    return np.where(total > 0, 2.0 * inter / np.maximum(total, 1), 1.0)


def frame_metrics(recon: np.ndarray, truth: np.ndarray, level: float) -> FrameMetrics:
    """MSE and foreground Dice per frame; foreground is intensity >= ``level`` in both images.

    recon, truth: [F, H, W] on the same grid and times.
    """
    if recon.shape != truth.shape:
        raise ValueError(f"recon shape {recon.shape} differs from truth shape {truth.shape}")
    diff = recon.astype(np.float64) - truth.astype(np.float64)
    mse = np.mean(diff**2, axis=(-2, -1))
    return FrameMetrics(mse=mse, dice=dice(recon >= level, truth >= level))


def summarise(m: FrameMetrics) -> dict:
    """Median, IQR and the share of good frames (MSE < 0.005, Dice > 0.85) of one method."""

    def stats(v: np.ndarray) -> tuple[float, list[float]]:
        q25, q50, q75 = np.percentile(v, [25, 50, 75])
        return float(q50), [float(q25), float(q75)]

    median_mse, iqr_mse = stats(m.mse)
    median_dice, iqr_dice = stats(m.dice)
    return {
        "median_mse": median_mse,
        "iqr_mse": iqr_mse,
        "median_dice": median_dice,
        "iqr_dice": iqr_dice,
        "share_mse_lt_0.005": float(np.mean(m.mse < MSE_GOOD)),
        "share_dice_gt_0.85": float(np.mean(m.dice > DICE_GOOD)),
        "per_frame": {"mse": m.mse.tolist(), "dice": m.dice.tolist()},
    }
