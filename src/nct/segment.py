"""Algorithm 1: find the K objects in FBP frames by a Gaussian mixture over intensities.

The mixture has K + kappa + 1 classes fitted on a random share of the frames. The class with the
most pixels is the background. Objects are brighter than the background in CT: going through
the brighter classes by peak height times contrast (pixels / spread x (mean - background
mean)), a class becomes the next object unless its mean lies within SAME_LEVEL standard
deviations (of the broader class) of an object already found or of the background (one level
split in two by the mixture). The paper keeps the classes with most pixels; on FBP frames of
moving objects that picks streak and partial-volume classes. Each pixel then goes to
the nearest of these levels, so the buffer classes (partial volume, streaks) shape the levels'
estimate but never claim pixels, and masks are thresholds between levels.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from sklearn.mixture import GaussianMixture

SAME_LEVEL = 3.0


@dataclass(frozen=True)
class Segmentation:
    """masks: [F, K, H, W] bool, one per object; intensities: [K] object minus background level."""

    masks: np.ndarray
    intensities: np.ndarray


def segment(
    frames: np.ndarray, n_objects: int, rng: np.random.Generator, kappa: int = 3, share: float = 0.02
) -> Segmentation:
    """Segment FBP ``frames`` [F, H, W] into ``n_objects`` masks, objects ordered by peak x contrast.

    The mixture is fitted on ``share`` of the frames (at least one), drawn with ``rng``.
    """
    if frames.ndim != 3:
        raise ValueError(f"frames must be [F, H, W], got shape {frames.shape}")
    if n_objects < 1:
        raise ValueError(f"n_objects must be >= 1, got {n_objects}")
    if kappa < 0:
        raise ValueError(f"kappa (buffer classes) must be >= 0, got {kappa}")
    n_fit = max(1, int(round(share * len(frames))))
    chosen = rng.choice(len(frames), size=n_fit, replace=False)
    n_classes = n_objects + kappa + 1
    gmm = GaussianMixture(n_classes, n_init=3, random_state=int(rng.integers(2**31 - 1)))
    gmm.fit(frames[chosen].reshape(-1, 1).astype(np.float64))
    labels = gmm.predict(frames.reshape(-1, 1).astype(np.float64))
    means = gmm.means_[:, 0]
    spread = np.sqrt(gmm.covariances_.reshape(n_classes))
    count = np.bincount(labels.ravel(), minlength=n_classes)
    background = int(np.argmax(count))
    # A true level is a sharp histogram peak (many pixels, small spread); partial-volume and
    # streak classes are broad. Rank by peak height times contrast.
    score = count / spread * (means - means[background])

    def same(a: int, b: int) -> bool:
        return abs(means[a] - means[b]) <= SAME_LEVEL * max(spread[a], spread[b])

    found: list[int] = []
    for c in np.argsort(-score):
        distinct = not any(same(c, o) for o in [background, *found])
        if means[c] > means[background] and distinct and len(found) < n_objects:
            found.append(int(c))
    if len(found) < n_objects:
        raise ValueError(
            f"found {len(found)} distinct intensity levels brighter than the background in the FBP frames, "
            f"need n_objects = {n_objects}"
        )
    levels = means[[background, *found]]
    nearest = np.argmin(np.abs(frames[..., None] - levels.astype(np.float32)), axis=-1)
    masks = np.stack([nearest == k + 1 for k in range(n_objects)], axis=1)
    return Segmentation(masks=masks, intensities=levels[1:] - levels[0])
