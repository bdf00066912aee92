"""Per-frame image quality against the truth (MSE, NRMSE, PSNR, SSIM, foreground Dice, Dice at each
object's own level) and its per-run summary."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from skimage.metrics import (
    normalized_root_mse,
    peak_signal_noise_ratio,
    structural_similarity,
)

#: A frame's MSE is good below this share of the truth's intensity range squared (`mse_bar`).
RELATIVE_MSE_GOOD = 0.005
DICE_GOOD = 0.85
SSIM_WINDOW = 7  # skimage's default window side (pixels), made smaller only for frames smaller than it


@dataclass(frozen=True)
class FrameMetrics:
    """One method's scores, arrays [F] float64 (one value per frame): mse in the data's intensity
    unit squared; nrmse = ||recon - truth|| / ||truth|| (unitless); psnr in dB and ssim (unitless,
    1 = identical) over the truth's intensity range ``data_range``; dice of the foreground masks.
    ``mse_good_below``: the MSE under which a frame counts as good (`mse_bar`). ``object_dice``
    [K, F]: Dice at each of ``object_levels`` (the truth's `Truth.levels`, one per object)."""

    mse: np.ndarray
    nrmse: np.ndarray
    psnr: np.ndarray
    ssim: np.ndarray
    dice: np.ndarray
    data_range: float
    mse_good_below: float
    object_levels: tuple[float, ...] = ()
    object_dice: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))


def dice(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Dice of boolean masks over the last two axes: [..., H, W] -> [...]; two empty masks score 1."""
    inter = np.logical_and(a, b).sum(axis=(-2, -1))
    total = a.sum(axis=(-2, -1)) + b.sum(axis=(-2, -1))
    return np.where(total > 0, 2.0 * inter / np.maximum(total, 1), 1.0)


def intensity_range(truth: np.ndarray) -> float:
    """The truth's intensity range over all frames (brightest minus darkest; its peak when flat):
    the scale that makes PSNR, SSIM and the MSE bar independent of the data's units."""
    span = float(np.ptp(truth))
    return span if span > 0 else float(np.abs(truth).max()) or 1.0


def mse_bar(data_range: float) -> float:
    """The MSE under which a frame is good: ``RELATIVE_MSE_GOOD`` x the truth's intensity range squared,
    i.e. an RMSE under 7 % of the contrast, PSNR above 23 dB, in any unit. For the built-in scenes
    (objects of intensity 1 on 0) this is the former fixed 0.005."""
    return RELATIVE_MSE_GOOD * data_range**2


def frame_metrics(recon: np.ndarray, truth: np.ndarray, level: float,
                  object_levels: Sequence[float] = ()) -> FrameMetrics:
    """Every score per frame. recon, truth: [F, H, W] on the same grid and times.

    Foreground (for Dice) is intensity >= ``level`` in both images, the truth's Dice level: half the
    faintest true object's intensity (``Truth.level``), so the same threshold, relative to the true
    intensities, scores FBP and NeuralCT; so is each object's mask at its own level (``Truth.levels``:
    a small object inside a larger one is scored at the container's level plus half its own).
    PSNR and SSIM use the truth's `intensity_range`.
    """
    if recon.shape != truth.shape:
        raise ValueError(f"recon shape {recon.shape} differs from truth shape {truth.shape}")
    recon, truth = recon.astype(np.float64), truth.astype(np.float64)
    span = intensity_range(truth)
    mse = np.mean((recon - truth) ** 2, axis=(-2, -1))
    with np.errstate(divide="ignore", invalid="ignore"):  # a perfect frame: PSNR inf; an empty truth frame: NRMSE inf
        psnr = np.array([peak_signal_noise_ratio(t, r, data_range=span) for t, r in zip(truth, recon)])
        nrmse = np.array([normalized_root_mse(t, r, normalization="euclidean") for t, r in zip(truth, recon)])
    side = min(truth.shape[-2:])
    window = min(SSIM_WINDOW, side if side % 2 else side - 1)
    ssim = np.array([structural_similarity(t, r, data_range=span, win_size=window) if window >= 3 else np.nan
                     for t, r in zip(truth, recon)])
    levels = tuple(float(v) for v in object_levels)
    at_levels = np.array([dice(recon >= v, truth >= v) for v in levels]).reshape(len(levels), len(truth))
    return FrameMetrics(mse, nrmse, psnr, ssim, dice(recon >= level, truth >= level), span, mse_bar(span), levels,
                        at_levels)


def summarise(m: FrameMetrics) -> dict:
    """Median and IQR of MSE and Dice, medians of NRMSE, PSNR and SSIM, and the share of good frames
    (MSE below ``mse_good_below``, Dice > 0.85) of one method; per-frame values under ``per_frame``;
    under ``objects``, each object's level and median Dice there (per frame: ``per_frame.object_dice``).
    The key ``share_mse_lt_0.005`` keeps its name: 0.005 is now relative (`mse_bar`)."""

    def stats(v: np.ndarray) -> tuple[float, list[float]]:
        q25, q50, q75 = np.percentile(v, [25, 50, 75])
        return float(q50), [float(q25), float(q75)]

    median_mse, iqr_mse = stats(m.mse)
    median_dice, iqr_dice = stats(m.dice)
    return {
        "median_mse": median_mse,
        "iqr_mse": iqr_mse,
        "median_nrmse": float(np.median(m.nrmse)),
        "median_psnr": float(np.median(m.psnr)),
        "median_ssim": float(np.median(m.ssim)),
        "median_dice": median_dice,
        "iqr_dice": iqr_dice,
        "data_range": m.data_range,
        "mse_good_below": m.mse_good_below,
        "share_mse_lt_0.005": float(np.mean(m.mse < m.mse_good_below)),
        "share_dice_gt_0.85": float(np.mean(m.dice > DICE_GOOD)),
        "objects": [{"level": v, "median_dice": float(np.median(d))} for v, d in zip(m.object_levels, m.object_dice)],
        "per_frame": {name: getattr(m, name).tolist()
                      for name in ("mse", "nrmse", "psnr", "ssim", "dice", "object_dice")},
    }


def quality_line(s: dict) -> str:
    """One method's summary for people, 3 significant digits: Dice, MSE, NRMSE, PSNR, SSIM, good frames,
    and Dice at each object's own level when there are several objects."""
    objects = s.get("objects", [])
    at_levels = "; at the objects' own levels " + ", ".join(
        f"{o['level']:.3g}: Dice {o['median_dice']:.3g}" for o in objects) if len(objects) > 1 else ""
    return (f"median Dice {s['median_dice']:.3g}, MSE {s['median_mse']:.3g} (intensity unit²), "
            f"NRMSE {s['median_nrmse']:.3g}, PSNR {s['median_psnr']:.3g} dB, SSIM {s['median_ssim']:.3g}; "
            f"frames with Dice > {DICE_GOOD}: {100 * s['share_dice_gt_0.85']:.0f} %, with MSE < "
            f"{s['mse_good_below']:.3g}: {100 * s['share_mse_lt_0.005']:.0f} %{at_levels}")
