"""Algorithm 2 (masks to signed distance frames) and Algorithm 6 (binarisation).

SDFs are in the image's physical units, positive inside. A pixel's distance is measured to the
boundary half a pixel beyond the last inside (or outside) pixel centre, so the zero level set
lies on pixel edges rather than on pixel centres.
"""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor

import numpy as np
from scipy.ndimage import distance_transform_edt


def masks_to_sdf(masks: np.ndarray, pixel_size: float, mask_tv: float = 0.5, sdf_tv: float = 0.1,
                 workers: int = 1) -> np.ndarray:
    """Smooth (TV), distance-transform and smooth again: masks [..., H, W] bool -> SDF [..., H, W] f32.

    ``mask_tv``: Chambolle TV weight for the 0/1 masks (0.5 removes rims a pixel or two wide,
    e.g. partial-volume pixels the segmentation gave to a fainter object); ``sdf_tv``: for the
    distances in pixels. ``workers``: threads smoothing images side by side (same result).
    """
    if masks.ndim < 2:
        raise ValueError(f"masks must be [..., H, W], got shape {masks.shape}")
    if not pixel_size > 0:
        raise ValueError(f"pixel_size must be > 0, got {pixel_size}")
    if mask_tv < 0 or sdf_tv < 0:
        raise ValueError(f"mask_tv and sdf_tv must be >= 0, got {mask_tv}, {sdf_tv}")
    flat = masks.reshape(-1, *masks.shape[-2:])
    seen: dict[bytes, int] = {}  # each distinct mask is smoothed once (a still object's frames, starts that agree)
    which = np.array([seen.setdefault(m.tobytes(), len(seen)) for m in flat])
    distinct = flat[np.unique(which, return_index=True)[1]]
    smooth = _tv(distinct.astype(np.float64), mask_tv, workers) > 0.5
    dist = np.stack([_signed_distance(m) for m in smooth])
    sdf = (_tv(dist, sdf_tv, workers) * pixel_size).astype(np.float32)
    return sdf[which].reshape(masks.shape)


def binarise(sdf: np.ndarray) -> np.ndarray:
    """Algorithm 6 for a centred occupancy ramp: inside where the SDF is positive. [...] -> bool."""
    return sdf > 0


def _tv(images: np.ndarray, weight: float, workers: int = 1) -> np.ndarray:
    """Chambolle TV denoising of each image of [N, H, W] on its own (no smoothing across N), on
    ``workers`` threads (numpy releases the GIL in the array work: about 1.6x on two cores)."""
    if weight == 0:
        return images
    with ThreadPoolExecutor(max(1, workers)) as pool:
        return np.stack(list(pool.map(lambda image: chambolle(image, weight), images)))


def chambolle(image: np.ndarray, weight: float, eps: float = 2e-4, max_num_iter: int = 200) -> np.ndarray:
    """scikit-image's ``denoise_tv_chambolle`` of one image [H, W] float64, step for step (the same
    operations in the same order: the same result to the bit, `tests/method/test_sdf.py`), with its
    arrays kept from one step to the next: a sixth less time, most of Algorithm 2's."""
    h, w = image.shape
    p, g, scratch = np.zeros((2, h, w)), np.zeros((2, h, w)), np.empty((2, h, w))
    d, out, norm = np.zeros((h, w)), image, np.empty((h, w))
    e_init = e_previous = 0.0
    for i in range(max_num_iter):
        if i > 0:  # d: the divergence of p, negated
            np.add(p[0], p[1], out=d)
            np.negative(d, out=d)
            d[1:, :] += p[0, :-1, :]
            d[:, 1:] += p[1, :, :-1]
            out = np.add(image, d, out=out if out is not image else None)
        energy = np.multiply(d, d, out=norm).sum()
        np.subtract(out[1:, :], out[:-1, :], out=g[0, :-1, :])  # g: the forward differences of out
        np.subtract(out[:, 1:], out[:, :-1], out=g[1, :, :-1])
        np.multiply(g, g, out=scratch)
        np.sqrt(np.add(scratch[0], scratch[1], out=norm), out=norm)
        energy = (energy + weight * norm.sum()) / float(image.size)
        norm *= 0.25 / weight  # tau = 1 / (2 ndim)
        norm += 1.0
        p -= np.multiply(g, 0.25, out=scratch)
        p /= norm
        if i == 0:
            e_init = e_previous = energy
        elif abs(e_previous - energy) < eps * e_init:
            break
        else:
            e_previous = energy
    return out if out is not image else image.copy()


def _signed_distance(mask: np.ndarray) -> np.ndarray:
    """Signed distance in pixels to the mask's edge, positive inside: [H, W] bool -> [H, W] f64."""
    if mask.all() or not mask.any():
        # No boundary in the image: call it as far away as the image is wide.
        return np.full(mask.shape, float(max(mask.shape)) * (1 if mask.all() else -1))
    inside = distance_transform_edt(mask) - 0.5
    outside = distance_transform_edt(~mask) - 0.5
    return np.where(mask, inside, -outside)
