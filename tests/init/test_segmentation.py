"""Algorithm 1: the Gaussian-mixture segmentation recovers object masks and intensities.

Every scene gets an initialisation: small, faint (noisy), fast, adjacent and nested objects
run end to end on tiny sizes without a crash and find their objects (issue 9, item 2).
Asking for more objects than the frames hold ends in seconds (issue 28 item 5).
"""

from __future__ import annotations

import math
import time

import numpy as np
import pytest
from scipy import ndimage

from nct.acquisition.scanner import ImageGrid
from nct.errors import NoObjectError
from nct.init.otsu import OTSU_WORK, otsu_bins, otsu_levels
from nct.init.segmentation import fill_holes, segment
from nct.run.metrics import dice
from tests.conftest import LONGER, OPTIM, fit_composed, orbit, still, two_object_frames


def test_recovers_masks_and_intensities_of_two_objects():
    images, truth = two_object_frames()
    seg = segment(images, 2, np.random.default_rng(0), share=0.1)
    assert seg.masks.shape == truth.shape and seg.masks.dtype == bool
    np.testing.assert_allclose(seg.intensities, [1.0, 0.4], atol=0.05)
    for k in range(2):
        assert dice(seg.masks[:, k], truth[:, k]).min() > 0.97


def test_one_object_ignores_streak_classes():
    """Negative streaks and a faint haze are buffer classes, never the object."""
    images, truth = two_object_frames()
    images = images - 0.4 * truth[:, 1]  # square gone; add a negative streak band and a faint haze
    images[:, 5:8, :] -= 0.3
    images[:, 30:40, 30:40] += 0.15
    seg = segment(images, 1, np.random.default_rng(1))
    assert seg.intensities[0] == pytest.approx(1.0, abs=0.05)
    assert dice(seg.masks[:, 0], truth[:, 0]).min() > 0.97


def test_same_rng_same_segmentation():
    images, _ = two_object_frames()
    a = segment(images, 2, np.random.default_rng(3))
    b = segment(images, 2, np.random.default_rng(3))
    np.testing.assert_array_equal(a.masks, b.masks)


def test_bad_input_is_named():
    images, _ = two_object_frames(4)
    with pytest.raises(ValueError, match="n_objects"):
        segment(images, 0, np.random.default_rng(0))
    with pytest.raises(ValueError, match=r"\[F, H, W\]"):
        segment(images[0], 1, np.random.default_rng(0))
    with pytest.raises(ValueError, match="route"):
        segment(images, 1, np.random.default_rng(0), route="kmeans")


def test_pure_noise_holds_no_object():
    """Only when nothing stands out of the background does segmentation stop, saying what it found."""
    noise = np.random.default_rng(0).normal(size=(3, 16, 16)).astype(np.float32) * 1e-3
    with pytest.raises(NoObjectError, match="found no object"):
        segment(noise, 1, np.random.default_rng(0))
    with pytest.raises(NoObjectError, match="Algorithm 1 found fewer"):
        segment(noise, 1, np.random.default_rng(0), route="gmm")


def test_more_objects_than_the_frames_hold_end_within_seconds():
    """data.n_objects=6 on two objects: multi-level Otsu into 6 classes on 256 bins searches 6 x C(255, 5)
    = 5e10 threshold sets (over 150 s before); on otsu_bins' coarser histogram, 55 bins, it takes 0.2 s
    and splits each object's level in three."""
    images, _ = two_object_frames()
    start = time.perf_counter()
    seg = segment(images, 6, np.random.default_rng(0), route="otsu")
    assert time.perf_counter() - start < 5 and seg.masks.shape[1] == 6
    for classes in range(2, 31):  # within OTSU_WORK for every count; untouched (256 bins) up to 4 classes
        bins = otsu_bins(classes)
        assert classes * math.comb(bins - 1, classes - 1) <= OTSU_WORK and (bins == 256) == (classes <= 4)


def test_fewer_filled_histogram_bins_than_objects_is_no_object_error():
    """Three distinct values on paper, two after binning (two levels, one with a 1e-7 ripple): found
    fewer levels than asked, not skimage's ValueError, so the fallback looks on at coarser scales."""
    x, y = ImageGrid(48).xy()
    disc, square = (x - 0.15) ** 2 + (y - 0.1) ** 2 < 0.15**2, (np.abs(x + 0.2) < 0.1) & (np.abs(y + 0.15) < 0.1)
    ripple = 1e-7 * np.random.default_rng(0).standard_normal(x.shape) * (disc | square)
    frames = np.stack([0.5 * disc + 1.0 * square + ripple] * 4).astype(np.float32)
    with pytest.raises(NoObjectError, match="found fewer than n_objects = 3 distinct levels"):
        otsu_levels(frames, 3)
    assert segment(frames, 3, np.random.default_rng(0), route="otsu").smoothing_px > 0


@pytest.mark.parametrize("noise_i0", [30.0, 10.0, 3.0])
def test_heavy_noise_still_gets_an_initialisation(noise_i0):
    """At a few photons per ray (Algorithm 1 alone crashed on some seeds at I0 = 3), the object is
    still found near its place: the masks overlap the disc's."""
    from nct.acquisition.scanner import Scanner
    from nct.physics.fbp import fbp_frames
    from nct.scenes.phantoms import CircleConf, build_phantom
    from nct.scenes.simulate import simulate

    grid, scanner = ImageGrid(48), Scanner(240, 1.0, 0.25, 0.0, 48, 1 / 48)
    phantom = build_phantom(CircleConf(radius=0.15, orbit_radius=0.2, displacement_deg=100.0), 0.25)
    times = (np.arange(12) + 0.5) * 0.25 / 12
    for seed in range(3):
        sino = simulate(phantom, scanner, grid, times, noise_i0, np.random.default_rng(seed))
        frames = fbp_frames(sino, grid, times)
        seg = segment(frames / np.percentile(frames, 99.9), 1, np.random.default_rng(seed))
        assert seg.intensities[0] > 0
        assert np.median(dice(seg.masks[:, 0], sino.truth.frames >= sino.truth.level)) > 0.5


def test_an_object_inside_a_dimmer_one_adds_to_it():
    """A vessel (level 1.5) inside a body (0.5): the body's mask is filled through the vessel and the
    vessel's intensity is what it adds (1.0); two objects apart keep their own levels and masks."""
    x, y = ImageGrid(48).xy()
    body, vessel = x**2 + y**2 < 0.35**2, (x - 0.1) ** 2 + y**2 < 0.08**2
    frames = np.stack([0.5 * body + 1.0 * vessel] * 4).astype(np.float32)
    seg = segment(frames, 2, np.random.default_rng(0), route="otsu")
    k_body = int(np.argmax(seg.masks.sum(axis=(0, 2, 3))))
    k_vessel = 1 - k_body
    assert dice(seg.masks[:, k_body], np.stack([body] * 4)).min() > 0.97  # no hole where the vessel is
    assert dice(seg.masks[:, k_vessel], np.stack([vessel] * 4)).min() > 0.95
    np.testing.assert_allclose(seg.intensities[[k_body, k_vessel]], [0.5, 1.0], atol=0.05)
    apart = np.stack([0.5 * (x**2 + y**2 < 0.15**2) + 1.5 * ((x - 0.3) ** 2 + y**2 < 0.08**2)] * 4).astype(np.float32)
    np.testing.assert_allclose(np.sort(segment(apart, 2, np.random.default_rng(0), route="otsu").intensities),
                               [0.5, 1.5], atol=0.05)


def test_a_nodule_in_a_lung_in_a_body_nests_in_the_lung_alone():
    """A lung (0.25) in a body (1.0) with a nodule (2.0) in the lung, slightly noisy: the lung nests in
    the body with a negative intensity (-0.75), the nodule in the innermost container (the lung: +1.75);
    the body's mask is filled through both, so no pixel holds the body without what lies inside it."""
    x, y = ImageGrid(64).xy()
    body, lung = (x / 0.35) ** 2 + (y / 0.25) ** 2 < 1, (x + 0.15) ** 2 + y**2 < 0.1**2
    nodule = (x + 0.15) ** 2 + (y - 0.02) ** 2 < 0.04**2
    image = np.where(nodule, 2.0, np.where(lung, 0.25, np.where(body, 1.0, 0.0)))
    frames = np.stack([image] * 4) + np.random.default_rng(0).normal(0.0, 0.02, (4, *image.shape))
    seg = segment(frames.astype(np.float32), 3, np.random.default_rng(0))
    order = np.argsort(-seg.masks.sum(axis=(0, 2, 3)))  # body, lung, nodule by area
    np.testing.assert_allclose(seg.intensities[order], [1.0, -0.75, 1.75], atol=0.05)
    for k, truth in zip(order, (body, lung, nodule)):
        assert dice(seg.masks[:, k], np.stack([truth] * 4)).min() > 0.97


def test_holes_are_filled_as_scipy_fills_each_image():
    """One labelling of a stack fills each image as scipy does one at a time: a hole stays a hole only within its
    own image (a background part touching the edge in the next image does not open it), rings and edges included."""
    rng = np.random.default_rng(0)
    for _ in range(60):
        shape = (*rng.integers(1, 5, size=2), *rng.integers(1, 24, size=2))
        masks = ndimage.binary_dilation(rng.random(shape) < rng.random() * 0.6)
        expected = np.stack([ndimage.binary_fill_holes(m) for m in masks.reshape(-1, *shape[-2:])]).reshape(shape)
        np.testing.assert_array_equal(fill_holes(masks), expected)
    ring = np.zeros((2, 7, 7), bool)
    ring[0, 1:6, 1:6], ring[0, 2:5, 2:5] = True, False  # a ring in the first image, nothing in the second
    assert fill_holes(ring)[0, 3, 3] and not fill_holes(ring)[1].any()


def test_each_candidate_is_judged_once():
    """With a judge, Algorithm 1's pick and the other choices of classes are each judged once: no
    two judged segmentations hold the same masks."""
    images, _ = two_object_frames()
    judged: list[bytes] = []

    def judge(masks, signs):
        judged.append(np.sort([m.tobytes() for m in masks.transpose(1, 0, 2, 3)]).tobytes())
        return float(len(judged)), np.ones(masks.shape[1])

    segment(images, 2, np.random.default_rng(0), share=0.1, judge=judge)
    assert len(judged) >= 2 and len(set(judged)) == len(judged)


GRID = ImageGrid(40)


SCENES = {  # objects, Poisson I0 (None: noiseless)
    "small": ([orbit(0.05, 0.2, 60.0, 1.0)], None),
    "small_noisy": ([orbit(0.05, 0.2, 60.0, 1.0)], 1e4),
    "small_fast": ([orbit(0.05, 0.2, 150.0, 1.0)], None),  # Algorithm 1 alone crashed here
    "small_fast_noisy": ([orbit(0.05, 0.2, 200.0, 1.0)], 1e4),
    "faint_noisy": ([orbit(0.12, 0.2, 100.0, 0.2)], 1e4),
    "adjacent": ([still(-0.1, 0.0, 0.1, 0.1, 1.0), orbit(0.08, 0.22, 60.0, 0.8)], None),
    "nested": ([still(0.0, 0.0, 0.38, 0.3, 0.5), orbit(0.06, 0.15, 100.0, 1.0)], None),
    "beside_static": ([orbit(0.1, 0.25, 100.0, 1.0), still(-0.2, -0.1, 0.12, 0.12, 0.5)], None),
}


# Small objects need a longer fit than the other method tests' 40 steps (measured on "small": overlap 0.00
# after 40 steps, 0.82 after 120, 0.85 after 200): the same 200 steps serve every scene scored here.


@pytest.mark.parametrize("name", SCENES)
def test_every_scene_gets_an_initialisation(name):
    objects, i0 = SCENES[name]
    sino, times, result = fit_composed(objects, GRID, OPTIM if "fast" in name else LONGER, i0)
    assert np.isfinite(result.frames).all() and result.frames.shape == (6, 40, 40)
    assert result.init["route"] in ("gmm", "otsu") and len(result.init["levels"]) == len(objects)
    assert all(a > 0 for a in result.intensities)
    if "fast" in name:
        return  # no crash is the bar here: a short fit of a small object this fast is not scored
    # Found where the objects are (a short fit need not reach their intensities yet): the
    # occupied pixels overlap the truth's objects.
    occupied = result.frames >= 0.5 * min(result.intensities)
    overlap = np.median(dice(occupied, sino.truth.frames >= sino.truth.level))
    assert overlap > 0.7, overlap  # measured 0.85-1.00
