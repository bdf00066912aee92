"""Projector against closed-form ellipse projections and scikit-image's radon: any ray step and
bin sampling, gradients, batches, bad input."""

from __future__ import annotations

import math
from functools import partial

import numpy as np
import pytest
import torch
from skimage.transform import radon

from nct.acquisition.geometry import FanGeometry, ParallelGeometry
from nct.acquisition.scanner import ImageGrid
from nct.physics.projector import forward_project, projector_for
from tests.conftest import ELLIPSES, bins, ellipse_image, ellipse_projection, rel_l2

ELLIPSE, SMALL_ELLIPSE = ELLIPSES
ANGLES = np.array([0.0, 0.3, 1.0, math.pi / 2, 2.2, 3.0, 4.5])


def project(image: np.ndarray, angles: np.ndarray, n_bins: int, spacing: float, **options) -> np.ndarray:
    result = forward_project(torch.tensor(image), torch.tensor(angles), 1.0, n_bins, spacing, **options)
    return result.numpy()


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


@pytest.mark.parametrize("geometry", [ParallelGeometry(20, 0.06), FanGeometry(20, 0.08, 3.0, 1.0, "curved")],
                         ids=["parallel", "fan"])
def test_sampling_grid_is_the_rays_p_plus_t_v_and_gradients_to_the_bit(geometry):
    """The grid written a coordinate at a time holds p + t v of every ray, bit for bit, and is contiguous: the
    image's gradient through it is that of the grid built in one broadcast (a grid of other strides rounds it
    otherwise)."""
    torch.manual_seed(0)
    projector = projector_for(geometry, 16, 1.0, None, 1, torch.device("cpu"), torch.float32)
    angles = torch.tensor([0.0, 0.7, 2.0, 5.5])
    point, direction = projector.unit_geometry.rays(angles, projector.u_norm.to(angles))
    down, t = projector.down.float(), projector.t_norm.float()
    plain = torch.addcmul((point * down)[:, :, None, :], t[None, None, :, None], (direction * down)[:, :, None, :])
    grid = projector.sampling_grid(angles)
    assert grid.is_contiguous() and torch.equal(grid, plain)
    images = torch.rand(4, 16, 16, requires_grad=True)
    views = projector.along(images, grid)
    (ours,) = torch.autograd.grad(views.square().sum(), images)
    (theirs,) = torch.autograd.grad(projector.along(images, plain).square().sum(), images)
    assert torch.equal(ours, theirs) and torch.equal(views, projector(images, angles))
    assert torch.equal(projector.along(images[2], grid), projector(images[2], angles))


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
