"""The static background under the moving objects (background.py): where it starts, how the objects are
then sought, and that a fit with it explains static surroundings the objects alone cannot."""

from __future__ import annotations

import logging
from dataclasses import replace

import numpy as np
import pytest
import torch
from scipy.ndimage import gaussian_filter

from nct.acquisition.scanner import ImageGrid, Scanner
from nct.fields.build import build_field
from nct.fit.conf import HeldoutConf, LossConf
from nct.fit.problem import prepare
from nct.fit.render import intensity
from nct.init.background import moving_problem, moving_region, static_start
from nct.init.conf import BackgroundConf
from nct.init.starts import find_starts
from nct.method.reconstruct import reconstruct
from nct.scenes.phantoms import ComposedConf, build_phantom
from nct.scenes.signals import Signal
from nct.scenes.simulate import simulate
from tests.conftest import INIT, LONGER, MODEL, TRAINER, orbit, still

GRID = ImageGrid(32)
# A static body with a darker static inclusion (not one level: an object model needs two objects for it)
# and a bright disc orbiting inside it at 60 deg/rotation: K = 1 moving object.
SCENE = [still(0.0, 0.0, 0.42, 0.34, 1.0), still(-0.2, 0.0, 0.1, 0.18, -0.6), orbit(0.1, 0.12, 60.0, 1.5)]


def frames_with(disc_at: list[tuple[int, int]], size: int = 32, radius: float = 3.0) -> np.ndarray:
    """FBP-like frames [F, size, size]: a static square of 1 (3/4 of the side), a disc of 2 whose centre is at
    ``disc_at`` (one per frame)."""
    rows, cols = np.mgrid[:size, :size]
    frames = np.zeros((len(disc_at), size, size), np.float32)
    frames[:, size // 8:size - size // 8, size // 8:size - size // 8] = 1.0
    for f, (r, c) in enumerate(disc_at):
        frames[f][(rows - r) ** 2 + (cols - c) ** 2 <= radius**2] = 2.0
    return frames


def test_the_moving_region_holds_the_moving_disc_and_not_the_still_square():
    frames = frames_with([(16, 10 + f) for f in range(8)])
    region = moving_region(frames, 0.35)
    assert region[16, 10:18].all()  # the disc's path, its still middle included
    assert not region[5, 5] and not region[26, 26] and not region[0, 0]


def slow_disc(size: int = 64) -> np.ndarray:
    """Blurred frames [10, size, size] of a disc of radius 9 moving 2 px right over `frames_with`'s square."""
    return gaussian_filter(frames_with([(32, 30 + f // 4) for f in range(10)], size, radius=9.0), (0, 1, 1))


def test_the_moving_region_holds_a_slow_movers_still_middle():
    """A slow disc changes only at its leading and trailing edges, two open crescents; its middle, always
    covered, belongs to the region too (benchmarks/results/background: holes000)."""
    region = moving_region(slow_disc(), 0.35)
    assert region[32, 22:41].all() and region[24:41, 32].all()
    assert not region[10, 10] and not region[54, 54] and not region[0, 0]


def test_a_still_part_larger_than_a_middle_stays_out_of_the_moving_region():
    """A still block as bright as the disc that it touches is a body (over MIDDLE_SHARE of the field), not
    the disc's middle: it stays out, and with it the middle it joins."""
    frames = slow_disc()
    frames[:, 8:56, 38:56] = 2.0  # over the disc's right half: its middle and the block are one still part
    region = moving_region(frames, 0.35)
    assert not region[10:54, 50].any() and not region[32, 32]


def test_the_background_starts_as_the_mean_with_the_moving_region_filled_from_around_it():
    frames = frames_with([(16, 10 + f) for f in range(8)])
    start = static_start(frames, 0.35)
    np.testing.assert_allclose(start.image[start.moving], 1.0)  # the square's level, not the disc's smear
    np.testing.assert_allclose(start.image[~start.moving], frames.mean(0)[~start.moving])


@pytest.fixture(scope="module")
def still_scene():
    """The scene's static part alone, prepared as a run would: a Problem."""
    scanner = Scanner(views_per_rotation=60, rotations=1.0, rotation_time=0.25, n_bins=40, bin_spacing=1 / 40)
    phantom = build_phantom(ComposedConf(objects=SCENE[:2]), scanner.rotation_time)
    sino = simulate(phantom, scanner, GRID, scanner.frame_times(6), None, np.random.default_rng(0))
    return prepare(sino, GRID, LossConf(), INIT, HeldoutConf(), "ramp", 180.0)


def test_the_objects_are_sought_in_what_moves(still_scene):
    """Over a background that is the whole scene, the object frames and views are (nearly) empty."""
    prob = still_scene
    moved = moving_problem(prob, static_start(prob.fbp, 0.35))
    assert np.abs(moved.fbp).max() < 0.05 * np.abs(prob.fbp).max()
    assert float(moved.views.values.abs().mean()) < 0.05 * float(prob.views.values.abs().mean())


def test_a_still_scene_over_a_background_says_nothing_moves(still_scene, caplog):
    with caplog.at_level(logging.WARNING, logger="nct.init.starts"):
        starts = find_starts(still_scene, 1, INIT, np.random.default_rng(0), BackgroundConf(name="image"))
    assert any("nothing moves" in r.getMessage() for r in caplog.records)
    assert starts[0].background is not None


def lone_start(objects: list) -> tuple:
    """The first start of ``objects`` with K = 1 over a background, 120 views: (its sightings, the phantom, init times s)."""
    scanner = Scanner(views_per_rotation=120, rotations=1.0, rotation_time=0.25, n_bins=40, bin_spacing=1 / 40)
    phantom = build_phantom(ComposedConf(objects=objects), scanner.rotation_time)
    sino = simulate(phantom, scanner, GRID, scanner.frame_times(6), None, np.random.default_rng(0))
    prob = prepare(sino, GRID, LossConf(), INIT, HeldoutConf(), "ramp", 180.0)
    seen = find_starts(prob, 1, INIT, np.random.default_rng(0), BackgroundConf(name="image"))[0].seen
    return seen, phantom, prob.init_times.double().numpy() * scanner.rotation_time


def test_one_object_over_a_background_is_held_on_its_focused_path():
    """K = 1 over a background: the start's poses are the disc's own path (the whole mass's, 1/10 of
    it the disc's, scaled into focus), held by the fit, within 0.5 px of the truth at every init time."""
    seen, phantom, times = lone_start(SCENE)
    truth = 2 * phantom.ellipses(times)[:, 2, :2]
    assert seen.held and np.hypot(*(seen.centres[:, 0].double().numpy() - truth).T).max() < 2 * 0.5 / 32


def test_one_object_among_other_changes_is_not_held_to_the_mass_centroid():
    """The dark inclusion breathing too (the views' mass changes): the centroid's path is not the
    disc's, and its poses start from the FBP masks, free."""
    breathing = replace(SCENE[1], a=Signal(0.1, amplitude=0.03, cycles_per_rotation=1.0))
    seen, _, _ = lone_start([SCENE[0], breathing, SCENE[2]])
    assert not seen.held


def test_the_field_holds_its_background_apart_from_its_shape():
    net = build_field(MODEL, 1, torch.Generator().manual_seed(0))
    assert net.background is None and "background" not in net.state_dict()
    net.set_background(torch.full((8, 8), 0.5))
    assert "background" in net.state_dict()
    assert all(p is not net.background for p in net.shape_parameters() + net.frame_parameters())
    sdf = torch.full((2, 1, 16, 16), -1.0)  # no object anywhere: the image is the background, resampled
    torch.testing.assert_close(intensity(sdf, net.intensities, 0.1, 50.0, net.background.detach()),
                               torch.full((2, 16, 16), 0.5))


@pytest.fixture(scope="module")
def fits():
    """The scene reconstructed with K = 1, with and without a background: {name: (truth, frames)}."""
    scanner = Scanner(views_per_rotation=120, rotations=1.0, rotation_time=0.25, n_bins=40, bin_spacing=1 / 40)
    phantom = build_phantom(ComposedConf(objects=SCENE), scanner.rotation_time)
    times = scanner.frame_times(6)
    sino = simulate(phantom, scanner, GRID, times, None, np.random.default_rng(0))
    out = {}
    for name in ("none", "image"):
        result = reconstruct(sino, GRID, times, MODEL, LossConf(tv_background=0.01), TRAINER, 0, logger="none",
                             n_objects=1, optim=LONGER, init=INIT, background=BackgroundConf(name=name))
        out[name] = sino.truth.frames, result.frames
    return out


def test_a_background_explains_the_static_surroundings(fits):
    mse = {name: float(np.mean((frames - truth) ** 2)) for name, (truth, frames) in fits.items()}
    assert mse["image"] < 0.3 * mse["none"]


def test_the_moving_disc_is_an_object_over_the_background(fits):
    truth, frames = fits["image"]
    disc = truth > 1.75  # the disc (1.5 over the body's 1.0) alone
    drawn = frames > 1.75
    dice = 2 * (disc & drawn).sum() / (disc.sum() + drawn.sum())
    assert dice > 0.8
