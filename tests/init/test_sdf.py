"""Algorithm 2 against scipy's distance transform and a disc's exact SDF; Algorithm 6."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.ndimage import distance_transform_edt
from skimage.restoration import denoise_tv_chambolle

from nct.acquisition.scanner import ImageGrid
from nct.init.sdf import binarise, chambolle, masks_to_sdf
from nct.run.metrics import dice

GRID = ImageGrid(64)
RADIUS = 0.25


def disc(cx: float = 0.05, cy: float = -0.03) -> tuple[np.ndarray, np.ndarray]:
    """A disc's mask and exact SDF (physical units, positive inside) on GRID."""
    x, y = GRID.xy()
    exact = RADIUS - np.hypot(x - cx, y - cy)
    return exact > 0, exact


def test_sdf_matches_distance_transform_away_from_boundary():
    mask, exact = disc()
    sdf = masks_to_sdf(mask, GRID.pixel_size)
    reference = (distance_transform_edt(mask) - distance_transform_edt(~mask)) * GRID.pixel_size
    px = GRID.pixel_size
    band = (np.abs(exact) > 2 * px) & (exact < RADIUS - 4 * px)  # off the boundary and the centre's ridge
    # Half a pixel apart by construction (edge vs pixel centre), and within a pixel of the exact SDF.
    np.testing.assert_allclose(np.abs(sdf - reference)[band], 0.5 * px, atol=0.25 * px)
    assert np.abs(sdf - exact)[band].max() < 0.8 * px


def test_sdf_positive_inside_negative_outside_and_binarises_back():
    mask, _ = disc()
    sdf = masks_to_sdf(mask, GRID.pixel_size)
    assert sdf.dtype == np.float32
    assert (sdf[mask] > 0).all() and (sdf[~mask] < 0).all()
    assert dice(binarise(sdf), mask) == 1.0


def test_batched_frames_are_independent():
    """[F, K, H, W]: each image on its own, as if converted alone."""
    a, _ = disc(0.1, 0.0)
    b, _ = disc(-0.1, 0.05)
    stack = np.stack([np.stack([a, b]), np.stack([b, a])])
    sdf = masks_to_sdf(stack, GRID.pixel_size)
    assert sdf.shape == stack.shape
    np.testing.assert_allclose(sdf[1, 0], masks_to_sdf(b, GRID.pixel_size), atol=1e-6)


def test_tv_removes_isolated_pixels_and_thin_rims():
    mask, _ = disc()
    noisy = mask.copy()
    noisy[5, 5] = True
    assert not binarise(masks_to_sdf(noisy, GRID.pixel_size))[5, 5]
    assert binarise(masks_to_sdf(noisy, GRID.pixel_size, mask_tv=0.0))[5, 5]
    ring = (np.abs(disc()[1]) < GRID.pixel_size) & ~mask  # a one-pixel rim just outside the disc
    assert not binarise(masks_to_sdf(ring, GRID.pixel_size)).any()


def test_empty_and_full_masks():
    empty = masks_to_sdf(np.zeros((8, 8), bool), 0.1)
    full = masks_to_sdf(np.ones((8, 8), bool), 0.1)
    assert (empty < 0).all() and (full > 0).all()


def test_bad_input_is_named():
    with pytest.raises(ValueError, match="pixel_size"):
        masks_to_sdf(np.zeros((4, 4), bool), 0.0)
    with pytest.raises(ValueError, match="mask_tv"):
        masks_to_sdf(np.zeros((4, 4), bool), 0.1, mask_tv=-1)


def test_threads_give_the_same_sdf():
    """Smoothing frames on several threads changes nothing but the time."""
    rng = np.random.default_rng(3)
    masks = rng.random((5, 24, 24)) > 0.6
    np.testing.assert_array_equal(masks_to_sdf(masks, 0.1, workers=3), masks_to_sdf(masks, 0.1))


@pytest.mark.parametrize(("weight", "max_num_iter"), [(0.5, 200), (0.1, 200), (0.5, 7)])
def test_chambolle_is_scikit_images_to_the_bit(weight: float, max_num_iter: int):
    """Its own arrays, the same arithmetic: a speckled mask and distances (stopped by the energy rule after
    4-76 steps), and runs cut off by ``max_num_iter``."""
    rng = np.random.default_rng(4)
    mask, _ = disc()
    speckled = mask ^ (rng.random(mask.shape) > 0.97)
    distances = distance_transform_edt(mask) - distance_transform_edt(~mask)
    for image in (speckled.astype(np.float64), distances):
        ours = chambolle(image, weight, max_num_iter=max_num_iter)
        np.testing.assert_array_equal(ours, denoise_tv_chambolle(image, weight=weight, max_num_iter=max_num_iter))
        assert not np.array_equal(ours, image)


def test_repeated_masks_get_the_sdf_each_would_alone():
    """A still object's frames are one mask repeated: smoothed once, each frame gets the SDF it has alone."""
    a, _ = disc(0.1, 0.0)
    b, _ = disc(-0.1, 0.05)
    stack = np.stack([a, b, a, a, b])
    sdf = masks_to_sdf(stack, GRID.pixel_size)
    for frame, mask in zip(sdf, stack):
        np.testing.assert_array_equal(frame, masks_to_sdf(mask, GRID.pixel_size))
