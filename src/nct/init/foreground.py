"""What stands out of the background in FBP frames: the pixel noise's deviation and the foreground
threshold, the lowest level an object may have (both routes of the segmentation use them)."""

from __future__ import annotations

import numpy as np

NOISE_SIGMAS = 4.0  # foreground: this many noise deviations above the background ...
MIN_CONTRAST = 0.05  # ... and at least this share of the brightest contrast (ripple of noiseless FBP)


def noise_sigma(frames: np.ndarray) -> float:
    """Robust standard deviation of the pixel noise: from neighbouring pixels' differences
    (edges are a small share of pixels, so the median ignores them)."""
    diff = np.diff(frames, axis=-1)
    return float(1.4826 * np.median(np.abs(diff - np.median(diff))) / np.sqrt(2))


def foreground_threshold(frames: np.ndarray, background: float, noise: float | None = None) -> float:
    """The lowest level an object may have: NOISE_SIGMAS noise deviations (``noise``, default
    measured on ``frames``) above ``background`` and MIN_CONTRAST of the brightest contrast (the
    99.9th percentile of the frames)."""
    peak = float(np.percentile(frames, 99.9))
    noise = noise_sigma(frames) if noise is None else noise
    return background + max(NOISE_SIGMAS * noise, MIN_CONTRAST * (peak - background))
