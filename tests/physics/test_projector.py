"""Projector and FBP against closed-form ellipse projections and scikit-image's radon/iradon.

FBP of fan-beam (and offset parallel) sinograms by rebinning onto parallel rays.
"""

from __future__ import annotations

import math
from functools import partial

import numpy as np
import pytest
import torch
from skimage.transform import iradon, radon

from nct.acquisition.geometry import FanGeometry
from nct.acquisition.rebin import parallel_geometry_for, to_parallel
from nct.acquisition.scanner import ImageGrid, Scanner
from nct.acquisition.sinogram import Sinogram
from nct.physics import projector
from nct.physics.projector import FILTERS, fbp, fbp_frames, forward_project
from nct.scenes.phantoms import StaticConf, build_phantom
from nct.scenes.simulate import simulate
from tests.conftest import GEOMETRIES, closed_form_sinogram, ellipse_image, rel_l2

ELLIPSE = (0.1, -0.05, 0.32, 0.22, 0.5, 1.0)
SMALL_ELLIPSE = (-0.18, 0.12, 0.1, 0.06, -0.4, 0.5)
ANGLES = np.array([0.0, 0.3, 1.0, math.pi / 2, 2.2, 3.0, 4.5])


def ellipse_projection(s: np.ndarray, angles: np.ndarray, ellipses) -> np.ndarray:
    """Closed-form line integrals of filled ellipses at detector positions s: [V, n_bins] float64.

    Along direction theta an ellipse of semi-axes a, b (a at angle phi) has support half-width
    r = sqrt(a^2 cos^2(theta - phi) + b^2 sin^2(theta - phi)) about its centre's s, and chord
    length 2 a b sqrt(r^2 - s'^2) / r^2 at offset s'.
    """
    total = np.zeros((len(angles), len(s)))
    for cx, cy, a, b, phi, value in ellipses:
        offset = s[None, :] - (cx * np.cos(angles) + cy * np.sin(angles))[:, None]
        r2 = ((a * np.cos(angles - phi)) ** 2 + (b * np.sin(angles - phi)) ** 2)[:, None]
        total += value * 2 * a * b * np.sqrt(np.clip(r2 - offset**2, 0, None)) / r2
    return total


def bins(n_bins: int, spacing: float) -> np.ndarray:
    return Scanner(n_bins=n_bins, bin_spacing=spacing).bin_positions


def dice(a: np.ndarray, b: np.ndarray) -> float:
    return float(2 * (a & b).sum() / (a.sum() + b.sum()))


def project(image: np.ndarray, angles: np.ndarray, n_bins: int, spacing: float, **options) -> np.ndarray:
    result = forward_project(torch.tensor(image), torch.tensor(angles), 1.0, n_bins, spacing, **options)
    return result.numpy()


# ---------------------------------------------------------------- forward projection


@pytest.mark.parametrize(
    "ray_step, bin_samples, n_bins",
    [(None, 1, 128), (1 / 256, 1, 128), (None, 4, 32)],
    ids=["default", "half-pixel-step", "coarse-bins-sub-sampled"],
)
def test_forward_matches_closed_form_ellipse(ray_step, bin_samples, n_bins):
    image = ellipse_image(ImageGrid(128), [ELLIPSE])
    spacing = 1 / n_bins
    got = project(image, ANGLES, n_bins, spacing, ray_step=ray_step, bin_samples=bin_samples)
    # Sub-bin rays average over the bin: compare with the closed form averaged over it too.
    offsets = np.linspace(-0.5, 0.5, 65) if bin_samples > 1 else np.zeros(1)
    s = bins(n_bins, spacing)
    expected = np.mean([ellipse_projection(s + o * spacing, ANGLES, [ELLIPSE]) for o in offsets], axis=0)
    assert rel_l2(got, expected) < 0.01


def test_forward_matches_skimage_radon():
    # Odd size: skimage's centre index n // 2 is then the geometric centre (n - 1) / 2.
    n = 65
    image = ellipse_image(ImageGrid(n), [ELLIPSE, SMALL_ELLIPSE])
    reference = radon(image, np.degrees(ANGLES), circle=True).T / n  # pixel units -> extent 1
    assert rel_l2(project(image, ANGLES, n, 1 / n), reference) < 0.01


@pytest.mark.parametrize("angle_deg", [0.0, 30.0, 90.0, 135.0, 250.0])
def test_blob_lands_where_s_equals_x_cos_plus_y_sin(angle_deg):
    n = 65
    grid = ImageGrid(n)
    x, y = grid.xy()
    x0, y0 = 0.2, 0.12  # right of and above the centre
    blob = np.exp(-((x - x0) ** 2 + (y - y0) ** 2) / (2 * (1.5 / n) ** 2)) * (np.hypot(x, y) < 0.45)
    theta = math.radians(angle_deg)
    expected = (x0 * math.cos(theta) + y0 * math.sin(theta)) * n + (n - 1) / 2  # in bins
    ours = project(blob, np.array([theta]), n, 1 / n)[0]
    theirs = radon(blob, [angle_deg], circle=True)[:, 0]
    for profile in (ours, theirs):
        centroid = (np.arange(n) * profile).sum() / profile.sum()
        assert centroid == pytest.approx(expected, abs=0.05)


def test_gradcheck_float64():
    torch.manual_seed(0)
    images = torch.rand(2, 5, 5, dtype=torch.float64, requires_grad=True)
    one_image = torch.rand(5, 5, dtype=torch.float64, requires_grad=True)
    angles = torch.tensor([0.3, 2.1], dtype=torch.float64)
    geometry = dict(angles=angles, extent=1.0, n_bins=4, bin_spacing=0.3)
    assert torch.autograd.gradcheck(partial(forward_project, **geometry), (images,))
    assert torch.autograd.gradcheck(partial(forward_project, **geometry, bin_samples=2), (one_image,))


def test_batched_equals_per_view_and_broadcast():
    torch.manual_seed(0)
    images = torch.rand(4, 16, 16)
    angles = torch.tensor([0.0, 0.7, 2.0, 5.5])
    batched = forward_project(images, angles, 1.0, 12, 0.1)
    single = torch.cat([forward_project(images[i : i + 1], angles[i : i + 1], 1.0, 12, 0.1) for i in range(4)])
    torch.testing.assert_close(batched, single)
    broadcast = forward_project(images[1], angles, 1.0, 12, 0.1)
    torch.testing.assert_close(broadcast, forward_project(images[1].expand(4, 16, 16), angles, 1.0, 12, 0.1))


@pytest.mark.parametrize(
    "images, angles",
    [
        (torch.zeros(2, 8, 6), torch.zeros(2)),  # not square
        (torch.zeros(2, 8, 8), torch.zeros(3)),  # one angle per image
        (torch.zeros(8), torch.zeros(1)),  # not an image
    ],
)
def test_forward_rejects_bad_shapes(images, angles):
    with pytest.raises(ValueError, match="images|angles"):
        forward_project(images, angles, 1.0, 8, 0.1)


def test_forward_rejects_bad_geometry():
    with pytest.raises(ValueError, match="bin_spacing"):
        forward_project(torch.zeros(1, 8, 8), torch.zeros(1), 1.0, 8, 0.0)


# ---------------------------------------------------------------- FBP


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
    monkeypatch.setattr(projector, "_CHUNK_SAMPLES", 7 * 33 * 33)
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


def rebinning_error(geometry, views: int = 360) -> float:
    """Relative L2 error of the rebinned closed-form sinogram against the closed form on the parallel rays."""
    angles = np.linspace(0, 2 * math.pi, views, endpoint=False)
    sino = Sinogram(closed_form_sinogram(geometry, angles).astype(np.float32), angles, np.arange(views) * 1e-3,
                    geometry)
    rebinned = to_parallel(sino)
    target = parallel_geometry_for(geometry)
    assert rebinned.geometry == target and rebinned.times is sino.times
    return rel_l2(rebinned.values, closed_form_sinogram(target, angles))


@pytest.mark.parametrize("geometry", GEOMETRIES.values(), ids=GEOMETRIES.keys())
def test_rebinned_sinogram_matches_the_parallel_closed_form(geometry):
    # Measured: 0 (centred parallel), 1.2 % (parallel offset by 3.84 bins), 0.55-0.78 % (fan): linear
    # interpolation between bins of chords with square-root edges.
    assert rebinning_error(geometry) < 0.015


def test_rebinning_error_falls_with_the_bin_pitch():
    coarse = GEOMETRIES["fan-flat"]
    fine = FanGeometry(coarse.n_bins * 4, coarse.bin_spacing / 4, coarse.source_distance, coarse.detector_distance)
    assert rebinning_error(fine, views=720) < rebinning_error(coarse, views=720) / 3


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
