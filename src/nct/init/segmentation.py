"""Find the K objects' levels and masks in FBP frames: Algorithm 1 (the paper's Gaussian mixture,
``mixture.py``) and, where it cannot separate K levels, a robust fallback (multi-level Otsu at coarser
scales, ``otsu.py``).

With a judge (``judge.py``: how well the masks explain the sinogram), Algorithm 1's rule only adds one
candidate: every choice of K of the mixture's classes above the foreground threshold, and the
fallback's levels, is judged, and the best explains the views; the judge also gives a(k).

Each pixel then goes to the nearest of these levels, so the buffer classes (partial volume,
streaks) shape the levels' estimate but never claim pixels, and masks are thresholds between levels.
An object inside another adds to it, negatively where darker (`nest`): the innermost container's
mask is filled through it.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from nct.errors import NoObjectError
from nct.init.conf import INIT_ROUTES
from nct.init.mixture import algorithm1_levels, class_choices, mixture_classes
from nct.init.otsu import smoothed_until_found


@dataclass(frozen=True)
class Segmentation:
    """masks: [F, K, H, W] bool, one per object; intensities: [K] object minus background level
    (minus its container's, for an object nested in a dimmer one: see `nest`);
    route: "gmm" (Algorithm 1) or "otsu" (the fallback); background: the background level;
    smoothing_px: the Gaussian scale at which the fallback found the objects (0: none);
    misfit: the judge's relative residual of the chosen levels (None: no judge)."""

    masks: np.ndarray
    intensities: np.ndarray
    route: str = "gmm"
    background: float = 0.0
    smoothing_px: float = 0.0
    misfit: float | None = None


Judge = Callable[[np.ndarray, np.ndarray], tuple[float, np.ndarray]]
"""Rates a candidate segmentation: masks [F, K, H, W] (nested), signs [K] of their intensities (+1, or -1
for an object darker than its container) -> (misfit, intensities [K]); lower is better."""


def segment(
    frames: np.ndarray, n_objects: int, rng: np.random.Generator, kappa: int = 3, share: float = 0.02,
    route: str = "auto", judge: Judge | None = None,
) -> Segmentation:
    """Segment FBP ``frames`` [F, H, W] into ``n_objects`` masks.

    ``route``: "gmm" (Algorithm 1 only), "otsu" (the fallback only) or "auto" (Algorithm 1, and
    the fallback where it finds fewer than K levels). The mixture is fitted on ``share`` of the
    frames (at least one), drawn with ``rng``. ``judge`` (None: Algorithm
    1's rule decides): every choice of K of the mixture's classes above the foreground threshold,
    and the fallback's levels, is judged and the lowest misfit wins, with the judge's intensities.
    Raises `NoObjectError` when nothing stands out.
    """
    return segmentations(frames, n_objects, rng, kappa, share, route, judge)[0]


def segmentations(
    frames: np.ndarray, n_objects: int, rng: np.random.Generator, kappa: int = 3, share: float = 0.02,
    route: str = "auto", judge: Judge | None = None,
) -> list[Segmentation]:
    """`segment`'s candidates, best first: with a judge, every distinct judged segmentation by
    rising misfit (ties keep Algorithm 1's order); without, the one the rule picks."""
    if frames.ndim != 3:
        raise ValueError(f"frames must be [F, H, W], got shape {frames.shape}")
    if n_objects < 1:
        raise ValueError(f"n_objects must be >= 1, got {n_objects}")
    if kappa < 0:
        raise ValueError(f"kappa (buffer classes) must be >= 0, got {kappa}")
    if route not in INIT_ROUTES:
        raise ValueError(f"route must be one of {INIT_ROUTES}, got {route!r}")
    if not np.isfinite(frames).all():
        raise NoObjectError("the FBP frames hold NaN or inf: the sinogram cannot be segmented")
    candidates: list[tuple[str, float, np.ndarray, np.ndarray]] = []  # route, smoothing_px, frames, levels [K + 1]
    if route != "otsu":
        classes = mixture_classes(frames, n_objects, rng, kappa, share)
        levels = algorithm1_levels(classes, n_objects)
        if levels is None and route == "gmm":
            raise NoObjectError(f"Algorithm 1 found fewer than n_objects = {n_objects} distinct intensity levels "
                                "brighter than the background in the FBP frames (init.route=auto falls back to Otsu)")
        if levels is not None:
            candidates.append(("gmm", 0.0, frames, levels))
        if judge is not None:  # Algorithm 1's own pick is one of the choices: judged once, in its order
            picked = None if levels is None else sorted(levels[1:])
            candidates += [("gmm", 0.0, frames, c) for c in class_choices(classes, n_objects)
                           if sorted(c[1:]) != picked]
    if route == "otsu" or judge is not None or not candidates:
        try:
            candidates.append(("otsu", *smoothed_until_found(frames, n_objects)))
        except NoObjectError:
            if not candidates:
                raise
    if judge is None:
        return [_segmentation(*candidates[0])]
    judged: list[Segmentation] = []
    for c in candidates:
        seg = _segmentation(*c, judge)
        if not any(np.array_equal(seg.masks, other.masks) for other in judged):
            judged.append(seg)
    return sorted(judged, key=lambda seg: seg.misfit)


def _segmentation(route: str, smoothing: float, frames: np.ndarray, levels: np.ndarray,
                  judge: Judge | None = None) -> Segmentation:
    """The masks that ``levels`` [K + 1] draw on ``frames``, nested; the judge's misfit and a(k) when given."""
    masks, intensities = nest(assign(frames, levels), levels)
    misfit = None
    if judge is not None:
        misfit, intensities = judge(masks, np.where(intensities < 0, -1.0, 1.0))
    return Segmentation(masks, intensities, route, float(levels[0]), smoothing, misfit)


def assign(frames: np.ndarray, levels: np.ndarray) -> np.ndarray:
    """Each pixel to the nearest of ``levels`` [K + 1] (background first): masks [F, K, H, W] bool."""
    nearest = np.argmin(np.abs(frames[..., None] - levels.astype(np.float32)), axis=-1)
    return np.stack([nearest == k + 1 for k in range(len(levels) - 1)], axis=1)


def nest(masks: np.ndarray, levels: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Objects inside another add to it, as attenuation does: where most of an object's pixels lie in
    the holes of another's mask, it nests in the innermost such container (the smallest filled mask),
    whose mask is filled through it, and its intensity becomes its level minus the container's
    (negative for a darker object, as a lung in a body). A static body around a moving vessel then
    stays static, with no moving hole to follow the vessel; a nodule in a lung in a body nests in the
    lung alone, and no pixel on the lung's rim holds both the body and the lung (a darker object
    keeps only its pixels inside its container: outside, its level is the container's blurred rim).
    masks [F, K, H, W] (one level each, as assigned), levels [K + 1] (background first) -> masks,
    intensities [K] (above the container, or the background)."""
    masks = masks.copy()
    intensities = levels[1:] - levels[0]
    filled = [fill_holes(masks[:, j]) for j in range(masks.shape[1])]
    area = [f.sum() for f in filled]
    containers = {}
    for k in range(masks.shape[1]):
        holders = [j for j in range(masks.shape[1]) if j != k and area[j] > area[k]
                   and (filled[j] & masks[:, k]).sum() > 0.5 * max(1, masks[:, k].sum())]
        if holders:
            containers[k] = min(holders, key=lambda j: area[j])
    for k in sorted(containers, key=lambda k: area[k]):  # innermost first, so a chain carries through
        j = containers[k]
        intensities[k] = levels[k + 1] - levels[j + 1]
        if intensities[k] < 0:  # a darker level's pixels outside its container are the container's rim
            masks[:, k] &= filled[j]
        masks[:, j] |= masks[:, k] & filled[j]
    return masks, intensities


def fill_holes(masks: np.ndarray) -> np.ndarray:
    """scipy's ``binary_fill_holes`` of each image of ``masks`` [..., H, W] bool on its own (what lies outside is
    the complement's 4-connected parts that touch the image's edge), for all images in one labelling: the same
    masks, without a call per image."""
    flat = masks.reshape(-1, *masks.shape[-2:])
    within = np.zeros((3, 3, 3), bool)
    within[1] = ndimage.generate_binary_structure(2, 1)  # 4-connected within an image, never across images
    parts, n = ndimage.label(~flat, within)
    outside = np.zeros(n + 1, bool)
    outside[np.concatenate([parts[:, 0], parts[:, -1], parts[:, :, 0], parts[:, :, -1]], axis=None)] = True
    outside[0] = False  # the masks' own pixels
    return ~outside[parts].reshape(masks.shape)
