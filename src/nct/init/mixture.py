"""Algorithm 1 (the paper's): a Gaussian mixture over the frames' intensities with K + kappa + 1 classes,
fitted on a random share of the frames. The class with the most pixels is the background. Objects are
brighter than the background in CT: going through the brighter classes by peak height times contrast
(pixels / spread x (mean - background mean)), a class becomes the next object unless its mean lies within
SAME_LEVEL standard deviations (of the broader class) of an object already found or of the background
(one level split in two by the mixture), or lies below the foreground threshold (background ripple or
noise; `foreground.foreground_threshold`). The paper keeps the classes with most pixels; on FBP frames of
moving objects that picks streak and partial-volume classes.

With a judge, every choice of K classes above the foreground threshold is a candidate (`class_choices`):
a class offers its mean as its level and, where a sharper class claims the pixels there, the median of
the pixels it claims (`claimed_levels`: a small object's few pixels in a broad class).
"""

from __future__ import annotations

from dataclasses import dataclass
from itertools import combinations, product

import numpy as np
from sklearn.mixture import GaussianMixture
from threadpoolctl import threadpool_limits

from nct.init.foreground import foreground_threshold

SAME_LEVEL = 3.0


@dataclass(frozen=True)
class MixtureClasses:
    """Algorithm 1's Gaussian mixture over the frames' pixels: per class its mean, spread, pixel
    count and claimed level (`claimed_levels`) [C]; ``background``: the class with most pixels;
    ``lowest``: the foreground threshold."""

    means: np.ndarray
    spread: np.ndarray
    count: np.ndarray
    background: int
    lowest: float
    claimed: np.ndarray

    @property
    def score(self) -> np.ndarray:
        """Peak height times contrast: a true level is a sharp histogram peak (many pixels, small
        spread); partial-volume and streak classes are broad."""
        return self.count / self.spread * (self.means - self.means[self.background])


def mixture_classes(frames: np.ndarray, n_objects: int, rng: np.random.Generator, kappa: int,
                    share: float) -> MixtureClasses:
    """Fit K + kappa + 1 Gaussian classes to ``share`` of the frames (at least one), drawn with ``rng``."""
    n_fit = max(1, int(round(share * len(frames))))
    sample = frames[rng.choice(len(frames), size=n_fit, replace=False)].reshape(-1)
    flat = frames.reshape(-1)
    n_classes = n_objects + kappa + 1
    gmm = GaussianMixture(n_classes, n_init=3, random_state=int(rng.integers(2**31 - 1)))
    with threadpool_limits(1):  # one-dimensional EM: BLAS threads on its tiny products cost 2-5x, results equal
        gmm.fit(sample.reshape(-1, 1).astype(np.float64))
    labels = predict_1d(gmm, flat)
    means = gmm.means_[:, 0]
    count = np.bincount(labels, minlength=n_classes)
    background = int(np.argmax(count))
    return MixtureClasses(means, np.sqrt(gmm.covariances_.reshape(n_classes)), count, background,
                          foreground_threshold(frames, float(means[background])), claimed_levels(gmm, flat, labels))


def claimed_levels(gmm: GaussianMixture, values: np.ndarray, labels: np.ndarray) -> np.ndarray:
    """Each class's level [C]: its mean, or, where a sharper class claims the pixels at its mean, the
    median of the pixels it does claim. A small object's few pixels (a nodule in a body: 17 a frame)
    can fall to a broad class whose mean sits on the body's peak; where its pixels are is the
    nodule's level, which no choice of the classes' means holds."""
    levels = gmm.means_[:, 0].copy()
    for c in np.flatnonzero(predict_1d(gmm, levels) != np.arange(len(levels))):
        claimed = values[labels == c]
        if claimed.size:
            levels[c] = float(np.median(claimed))
    return levels


def predict_1d(gmm: GaussianMixture, values: np.ndarray, chunk: int = 1 << 20) -> np.ndarray:
    """``gmm.predict`` for one-dimensional ``values`` [N]: the class of highest weighted log
    density, computed directly; the same labels as ``predict``, about 8x faster on the million
    pixels of the default run, whose general path costs about a second there."""
    var = gmm.covariances_.reshape(-1)
    offset = np.log(gmm.weights_) - 0.5 * np.log(2 * np.pi * var)
    mean = gmm.means_[:, 0]
    parts = [np.argmax(offset - 0.5 * (part.astype(np.float64)[:, None] - mean) ** 2 / var, axis=1)
             for part in np.array_split(values, max(1, -(-len(values) // chunk)))]
    return np.concatenate(parts)


def algorithm1_levels(classes: MixtureClasses, n_objects: int) -> np.ndarray | None:
    """Algorithm 1: background and K object levels [K + 1] ordered by peak x contrast, or None
    when the mixture does not hold K distinct levels above the foreground threshold."""
    means, spread = classes.means, classes.spread

    def same(a: int, b: int) -> bool:
        return abs(means[a] - means[b]) <= SAME_LEVEL * max(spread[a], spread[b])

    found: list[int] = []
    for c in np.argsort(-classes.score):
        distinct = not any(same(c, o) for o in [classes.background, *found])
        if means[c] >= classes.lowest and distinct and len(found) < n_objects:
            found.append(int(c))
    return means[[classes.background, *found]] if len(found) == n_objects else None


def class_choices(classes: MixtureClasses, n_objects: int) -> list[np.ndarray]:
    """Every choice of K classes' levels above the foreground threshold as levels [K + 1] (background
    first); a class whose claimed level differs from its mean offers both."""
    options = {c: [lv for lv in dict.fromkeys([classes.means[c], classes.claimed[c]]) if lv >= classes.lowest]
               for c in range(len(classes.means)) if c != classes.background}
    above = [c for c in options if options[c]]
    return [np.asarray([classes.means[classes.background], *levels])
            for chosen in combinations(above, n_objects) for levels in product(*(options[c] for c in chosen))]
