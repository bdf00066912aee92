"""Algorithm 2 (masks to signed distance frames) and Algorithm 6 (binarisation).

SDFs are in the image's physical units, positive inside. A pixel's distance is measured to the
boundary half a pixel beyond the last inside (or outside) pixel centre, so the zero level set
lies on pixel edges rather than on pixel centres.
"""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor

import numpy as np
from scipy.ndimage import distance_transform_edt
from skimage.restoration import denoise_tv_chambolle


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
    smooth = _tv(flat.astype(np.float64), mask_tv, workers) > 0.5
    dist = np.stack([_signed_distance(m) for m in smooth])
    return (_tv(dist, sdf_tv, workers) * pixel_size).astype(np.float32).reshape(masks.shape)


def binarise(sdf: np.ndarray) -> np.ndarray:
    """Algorithm 6 for a centred occupancy ramp: inside where the SDF is positive. [...] -> bool."""
    return sdf > 0


def _tv(images: np.ndarray, weight: float, workers: int = 1) -> np.ndarray:
    """Chambolle TV denoising of each image of [N, H, W] on its own (no smoothing across N), on
    ``workers`` threads (numpy releases the GIL in the array work: about 1.6x on two cores)."""
    if weight == 0:
        return images
    with ThreadPoolExecutor(max(1, workers)) as pool:
        return np.stack(list(pool.map(lambda image: denoise_tv_chambolle(image, weight=weight), images)))


def _signed_distance(mask: np.ndarray) -> np.ndarray:
    """Signed distance in pixels to the mask's edge, positive inside: [H, W] bool -> [H, W] f64."""
    if mask.all() or not mask.any():
        # No boundary in the image: call it as far away as the image is wide.
        return np.full(mask.shape, float(max(mask.shape)) * (1 if mask.all() else -1))
    inside = distance_transform_edt(mask) - 0.5
    outside = distance_transform_edt(~mask) - 0.5
    return np.where(mask, inside, -outside)
