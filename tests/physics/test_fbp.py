"""FBP against closed-form ellipse projections and scikit-image's iradon; FBP frames' windows of views
about each time; FBP of fan-beam (and offset parallel) sinograms by rebinning onto parallel rays."""

from __future__ import annotations

import math

import numpy as np
import pytest
from skimage.transform import iradon

from nct.acquisition.scanner import ImageGrid, Scanner
from nct.acquisition.sinogram import Sinogram
from nct.physics import fbp as fbp_module
from nct.physics.conf import FILTERS
from nct.physics.fbp import fbp, fbp_frames
from nct.scenes.phantoms import StaticConf, build_phantom
from nct.scenes.simulate import simulate
from tests.conftest import ELLIPSES, GEOMETRIES, bins, dice, ellipse_image, ellipse_projection, rel_l2

ELLIPSE, SMALL_ELLIPSE = ELLIPSES


def analytic_sinogram(n: int, angles: np.ndarray, ellipses=(ELLIPSE,)) -> np.ndarray:
    return ellipse_projection(bins(n, 1 / n), angles, list(ellipses)).astype(np.float32)


ANGLE_SETS = {
    "uniform-180": np.linspace(0, math.pi, 90, endpoint=False) + 0.3,
    # Three times denser in the first quarter turn: per-view weights must follow the spacing.
    "clustered-180": np.concatenate(
        (np.linspace(0, math.pi / 2, 60, endpoint=False), np.linspace(math.pi / 2, math.pi, 20, endpoint=False))
    )
    + 0.3,
    "uniform-360": np.linspace(0, 2 * math.pi, 180, endpoint=False),
}


@pytest.mark.parametrize("angle_set", ANGLE_SETS)
def test_fbp_static_ellipse_dice(angle_set):
    n = 64
    grid = ImageGrid(n)
    angles = ANGLE_SETS[angle_set]
    recon = fbp(analytic_sinogram(n, angles), angles, grid, 1 / n)
    truth = ellipse_image(grid, [ELLIPSE])
    assert recon.dtype == np.float32 and recon.shape == (n, n)
    assert dice(recon > 0.5, truth > 0.5) >= 0.98
    inside = np.hypot(*grid.xy()) < 0.45
    assert rel_l2(recon[inside], truth[inside]) < 0.08


@pytest.mark.parametrize("filter", FILTERS)
def test_fbp_matches_skimage_iradon(filter):
    n = 65  # odd: skimage's centre is the geometric centre
    grid = ImageGrid(n)
    angles = np.linspace(0, math.pi, 60, endpoint=False)
    sino = analytic_sinogram(n, angles, (ELLIPSE, SMALL_ELLIPSE))
    ours = fbp(sino, angles, grid, 1 / n, filter=filter)
    theirs = iradon(sino.T * n, np.degrees(angles), filter_name=filter, circle=True)
    inside = np.hypot(*grid.xy()) < 0.48
    assert rel_l2(ours[inside], theirs[inside]) < 2e-3


def test_fbp_360_degrees_has_the_180_degree_scale():
    n = 48
    half = np.linspace(0, math.pi, 60, endpoint=False)
    full = np.linspace(0, 2 * math.pi, 120, endpoint=False)
    a = fbp(analytic_sinogram(n, half), half, ImageGrid(n), 1 / n)
    b = fbp(analytic_sinogram(n, full), full, ImageGrid(n), 1 / n)
    np.testing.assert_allclose(b, a, atol=1e-5)


def test_unknown_filter_names_the_key_and_choices():
    with pytest.raises(ValueError, match=r"fbp\.filter.*ramp, shepp-logan, cosine, hamming, hann"):
        fbp(np.zeros((4, 8), np.float32), np.linspace(0, 3, 4), ImageGrid(8), 0.125, filter="butterworth")


# ---------------------------------------------------------------- FBP frames


def scan(views_per_rotation=72, rotations=2.0, n=33, start_angle=0.3, ellipses=(ELLIPSE,), gain=None) -> Sinogram:
    """Analytic sinogram of static ellipses, each view optionally scaled by gain(time)."""
    scanner = Scanner(views_per_rotation, rotations, 0.25, start_angle, n, 1 / n)
    values = ellipse_projection(scanner.bin_positions, scanner.angles, list(ellipses))
    if gain is not None:
        values = values * gain(scanner.times)[:, None]
    return Sinogram(values.astype(np.float32), scanner.angles, scanner.times, scanner.geometry)


def test_static_scene_frames_all_equal_fbp_of_half_turn():
    sino = scan()
    grid = ImageGrid(33)
    frames = fbp_frames(sino, grid, np.array([0.0, 0.1, 0.26, 0.3, 0.5]))
    reference = fbp(sino.values[:36], sino.angles[:36], grid, sino.geometry.bin_spacing)
    assert frames.dtype == np.float32 and frames.shape == (5, 33, 33)
    np.testing.assert_allclose(frames, np.broadcast_to(reference, frames.shape), atol=1e-5)


def test_full_turn_window_equals_full_rotation_fbp():
    sino = scan(rotations=1.0)
    grid = ImageGrid(33)
    frames = fbp_frames(sino, grid, np.linspace(0, 0.25, 4), window_deg=360)
    reference = fbp(sino.values, sino.angles, grid, sino.geometry.bin_spacing)
    np.testing.assert_allclose(frames, np.broadcast_to(reference, frames.shape), atol=1e-5)


def test_windows_are_centred_on_the_nearest_view_and_clamped():
    # A centred disc: every view's filtered profile is the same, so the centre pixel of a frame is
    # that of the static frame times the mean view gain over the window; a linear gain in time
    # then reads off each window's mean time. 185 deg = 37 views (odd): exactly centred on a view.
    rate = 2.0
    disc = ((0.0, 0.0, 0.25, 0.25, 0.0, 1.0),)
    grid = ImageGrid(33)  # odd: a pixel sits at the centre
    moving = scan(ellipses=disc, gain=lambda t: 1 + rate * t)
    static = scan(ellipses=disc)
    dt = moving.times[1]
    times = np.array([0.0, 0.1, 0.2013, 0.3, moving.times[-1]])  # nearest views 0, 29, 58, 86, 143
    centre = 33 // 2
    frames = fbp_frames(moving, grid, times, window_deg=185)[:, centre, centre]
    ratio = frames / fbp_frames(static, grid, times, window_deg=185)[:, centre, centre]
    window_mean_time = (ratio - 1) / rate
    expected = np.array([18, 29, 58, 86, 143 - 18]) * dt  # the first and last windows clamped
    np.testing.assert_allclose(window_mean_time, expected, atol=0.01 * dt)


def test_chunked_running_sums_match_one_chunk(monkeypatch):
    sino = scan()
    grid = ImageGrid(33)
    times = np.linspace(0, 0.5, 9)
    whole = fbp_frames(sino, grid, times, window_deg=90)
    # 7 views a chunk: window boundaries fall inside chunks and sums run across them.
    monkeypatch.setattr(fbp_module, "_CHUNK_SAMPLES", 7 * 33 * 33)
    np.testing.assert_allclose(fbp_frames(sino, grid, times, window_deg=90), whole, atol=1e-5)
    np.testing.assert_allclose(
        fbp(sino.values, sino.angles, grid, sino.geometry.bin_spacing),
        fbp(sino.values[:72], sino.angles[:72], grid, sino.geometry.bin_spacing),
        atol=1e-5,
    )


def test_wrapped_angles_give_the_same_frames():
    sino = scan()
    wrapped = Sinogram(sino.values, np.mod(sino.angles, 2 * math.pi), sino.times, sino.geometry)
    times = np.array([0.05, 0.25, 0.45])
    expected = fbp_frames(sino, ImageGrid(33), times)
    np.testing.assert_allclose(fbp_frames(wrapped, ImageGrid(33), times), expected, atol=1e-5)


def test_short_acquisition_uses_all_views_and_warns():
    sino = scan(rotations=0.4)  # 144 degrees
    grid = ImageGrid(33)
    with pytest.warns(UserWarning, match="window_deg") as caught:
        frames = fbp_frames(sino, grid, np.array([0.0, 0.05, 0.1]))
    assert len(caught) == 1
    reference = fbp(sino.values, sino.angles, grid, sino.geometry.bin_spacing)
    np.testing.assert_allclose(frames, np.broadcast_to(reference, frames.shape), atol=1e-5)


@pytest.mark.parametrize("window_deg", [0.0, -90.0, 361.0])
def test_window_deg_is_validated(window_deg):
    with pytest.raises(ValueError, match=r"fbp\.window_deg"):
        fbp_frames(scan(rotations=1.0), ImageGrid(33), np.array([0.1]), window_deg=window_deg)


N = 64


def static_scan(geometry, views_per_rotation: int = 360, rotations: float = 1.0):
    scanner = Scanner(views_per_rotation, rotations, 0.25, 0.3, **{"n_bins": geometry.n_bins, **geometry.keys()})
    phantom = build_phantom(StaticConf(), scanner.rotation_time)
    return simulate(phantom, scanner, ImageGrid(N), np.array([0.0]), None, np.random.default_rng(0))


# Measured at 64^2, 360 views: 0.991 (flat), 0.994 (curved), offsets the same; centred parallel beam with
# its coarser pitch (one pixel) 0.980, offset by 3.84 bins 0.976 (rebinning interpolates between bins).
MIN_DICE = {name: 0.98 for name in GEOMETRIES} | {"parallel": 0.975, "parallel-offset": 0.97}


@pytest.mark.parametrize("name", GEOMETRIES)
def test_fbp_of_static_pair_from_analytic_sinogram(name):
    sino = static_scan(GEOMETRIES[name])
    recon = fbp_frames(sino, ImageGrid(N), np.array([0.1]), window_deg=360)[0]
    truth = sino.truth.frames[0]
    assert dice(recon > sino.truth.level, truth > sino.truth.level) >= MIN_DICE[name]


@pytest.mark.parametrize("name", ["fan-flat", "fan-curved-offset"])
def test_short_scan_of_180_plus_fan_angle_reaches_dice_098(name):
    geometry = GEOMETRIES[name]
    fan_angle = 2 * float(np.abs(geometry.fan_angle(geometry.bin_edges)).max())
    views = 360
    rotations = (math.pi + fan_angle) / (2 * math.pi) + 1.0 / views
    sino = static_scan(geometry, views, rotations)
    middle = np.array([sino.times[-1] / 2])
    recon = fbp_frames(sino, ImageGrid(N), middle, window_deg=180)[0]
    truth = sino.truth.frames[0]
    assert dice(recon > sino.truth.level, truth > sino.truth.level) >= 0.98
