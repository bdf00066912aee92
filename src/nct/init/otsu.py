"""The segmentation's fallback where the mixture cannot separate K levels (a small or fast object seen in
few pixels of the frames it was fitted on, a faint object beside a bright one, noise): the foreground
pixels of every frame (above `foreground.foreground_threshold`) split into K classes by multi-level Otsu
(on a histogram coarse enough to bound its cost: `otsu_bins`), each class's median its level; where noise
hides every object at the pixel scale, it looks again on frames smoothed at coarser scales (SMOOTHING_PX).
Only when nothing stands out of the background at any scale does it fail, with `NoObjectError`.
"""

from __future__ import annotations

import math
from itertools import pairwise

import numpy as np
from scipy.ndimage import gaussian_filter
from skimage.filters import threshold_multiotsu

from nct.errors import NoObjectError
from nct.init.foreground import foreground_threshold, noise_sigma

SMOOTHING_PX = (0.0, 1.0, 2.0, 4.0)  # scales (Gaussian sigma, pixels) at which the fallback looks for objects
OTSU_BINS = 256  # skimage's default histogram for multi-level Otsu ...
OTSU_WORK = 2e7  # ... made coarser where classes x threshold combinations would exceed this (about 0.15 s)


def smoothed_until_found(frames: np.ndarray, n_objects: int) -> tuple[float, np.ndarray, np.ndarray]:
    """The finest of SMOOTHING_PX (Gaussian, in space only) at which K objects stand out of the
    noise, the frames smoothed at that scale and their Otsu levels [K + 1]: noise too heavy for
    single pixels can still show an object at a coarser scale. `NoObjectError` (the coarsest
    scale's) when none holds them."""
    sigma = noise_sigma(frames)
    for px in SMOOTHING_PX:
        smooth = gaussian_filter(frames, (0, px, px)) if px else frames
        try:
            return px, smooth, otsu_levels(smooth, n_objects, smoothed_noise(sigma, px))
        except NoObjectError as err:
            failure = err
    raise failure


def smoothed_noise(sigma: float, px: float) -> float:
    """Noise deviation left after a Gaussian of ``px`` pixels, for white noise of deviation
    ``sigma`` (FBP noise, ramp-filtered, loses more: this errs high, so on the safe side).
    Measured on the smoothed frames themselves it would read far too low: their neighbours agree."""
    return sigma if px == 0 else sigma / (2 * np.sqrt(np.pi) * px)


def otsu_levels(frames: np.ndarray, n_objects: int, noise: float | None = None) -> np.ndarray:
    """The fallback: background (the median pixel) and K object levels [K + 1], brightest last,
    from a multi-level Otsu split of the foreground pixels into K classes (class medians).
    ``noise``: the frames' noise deviation (default: measured on them)."""
    background = float(np.median(frames))
    lowest = foreground_threshold(frames, background, noise)
    fg = frames[frames > lowest].astype(np.float64)
    if fg.size < len(frames) or np.unique(fg).size < max(2, n_objects):  # under a pixel a frame: noise
        raise NoObjectError(
            f"found no object in the FBP frames: {fg.size} pixels stand out of the background level "
            f"{background:.4g} (threshold {lowest:.4g}), need n_objects = {n_objects} distinct levels; "
            "is the sinogram empty, or data.n_objects too large?")
    try:
        thresholds = threshold_multiotsu(fg, classes=n_objects, nbins=otsu_bins(n_objects)) if n_objects > 1 else []
        parts = [fg[(fg > lo) & (fg <= hi)] for lo, hi in pairwise([lowest, *thresholds, np.inf])]
    except ValueError:  # the histogram holds fewer filled bins than K
        parts = []
    if len(parts) < n_objects or any(part.size == 0 for part in parts):
        raise NoObjectError(f"found fewer than n_objects = {n_objects} distinct levels in the FBP frames' "
                            f"foreground ({fg.size} pixels above {lowest:.4g})")
    return np.asarray([background, *(float(np.median(part)) for part in parts)])


def otsu_bins(classes: int) -> int:
    """The finest histogram, up to OTSU_BINS, on which multi-level Otsu into ``classes`` stays within
    OTSU_WORK: skimage searches every set of thresholds, classes x C(bins - 1, classes - 1) of them
    (measured about 6 ns each; at 256 bins 4 classes take 0.06 s, 5 classes 6.5 s, 6 classes minutes)."""
    bins = OTSU_BINS
    while bins > classes and classes * math.comb(bins - 1, classes - 1) > OTSU_WORK:
        bins -= 1
    return bins
