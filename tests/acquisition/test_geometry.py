"""Geometry and projector over every geometry: closed-form chords, the convention, adjointness, validation."""

from __future__ import annotations

import math

import numpy as np
import pytest
import torch

from nct.acquisition.geometry import FanGeometry, ParallelGeometry, make_geometry
from nct.acquisition.scanner import ImageGrid, Scanner
from nct.physics.projector import project
from tests.conftest import (
    ELLIPSES,
    GEOMETRIES,
    closed_form_sinogram,
    detector_u,
    ellipse_chords,
    ellipse_image,
    reference_rays,
    rel_l2,
)

ANGLES = np.array([0.0, 0.3, 1.0, math.pi / 2, 2.2, 3.0, 4.5])
EVERY = pytest.mark.parametrize("geometry", GEOMETRIES.values(), ids=GEOMETRIES.keys())
FAN = {k: g for k, g in GEOMETRIES.items() if isinstance(g, FanGeometry)}


def test_closed_form_centred_disc_chord_is_2_sqrt_r2_minus_p2():
    # The test's own reference, checked on the simplest case: p = source_distance |sin gamma|.
    radius = 0.3
    for geometry in FAN.values():
        got = closed_form_sinogram(geometry, ANGLES, [(0.0, 0.0, radius, radius, 0.0, 1.0)])
        u = detector_u(geometry)
        d_total = geometry.source_distance + geometry.detector_distance
        gamma = np.arctan(u / d_total) if geometry.detector_shape == "flat" else u / d_total
        p = geometry.source_distance * np.abs(np.sin(gamma))
        expected = 2 * np.sqrt(np.clip(radius**2 - p**2, 0, None))
        np.testing.assert_allclose(got, np.broadcast_to(expected, got.shape), atol=1e-12)


@EVERY
def test_rays_follow_the_convention(geometry):
    point, direction = geometry.rays(ANGLES)
    ref_point, ref_direction = reference_rays(geometry, ANGLES, detector_u(geometry))
    np.testing.assert_allclose(np.abs((direction * ref_direction).sum(-1)), 1.0, atol=1e-12)
    # The geometry's point lies on the reference ray.
    offset = point - ref_point
    np.testing.assert_allclose(offset[..., 0] * ref_direction[..., 1] - offset[..., 1] * ref_direction[..., 0], 0,
                               atol=1e-12)


@EVERY
def test_projector_matches_closed_form_chords(geometry):
    image = ellipse_image(ImageGrid(128))
    got = project(torch.tensor(image), torch.tensor(ANGLES), geometry, 1.0).numpy()
    expected = closed_form_sinogram(geometry, ANGLES)
    assert rel_l2(got, expected) < 0.01


@EVERY
def test_sub_bin_rays_average_the_bin(geometry):
    image = ellipse_image(ImageGrid(128))
    got = project(torch.tensor(image), torch.tensor(ANGLES), geometry, 1.0, bin_samples=4).numpy()
    assert rel_l2(got, closed_form_sinogram(geometry, ANGLES, sub_rays=4)) < 0.01


@EVERY
def test_blob_lands_where_the_convention_projects_it(geometry):
    n = 65
    x, y = ImageGrid(n).xy()
    x0, y0 = 0.2, 0.12
    blob = np.exp(-((x - x0) ** 2 + (y - y0) ** 2) / (2 * (1.5 / n) ** 2))
    for theta in (0.0, 0.5, 2.0, 4.0):
        s = x0 * math.cos(theta) + y0 * math.sin(theta)
        r = -x0 * math.sin(theta) + y0 * math.cos(theta)
        if isinstance(geometry, ParallelGeometry):
            expected = s
        else:
            d, d_total = geometry.source_distance, geometry.source_distance + geometry.detector_distance
            flat = geometry.detector_shape == "flat"
            expected = d_total * s / (d + r) if flat else d_total * math.atan(s / (d + r))
        u, _ = geometry.project_points(np.array([x0]), np.array([y0]), np.array([theta]))
        assert float(u[0, 0]) == pytest.approx(expected, abs=1e-12)
        profile = project(torch.tensor(blob), torch.tensor([theta]), geometry, 1.0).numpy()[0]
        centroid = (detector_u(geometry) * profile).sum() / profile.sum()
        assert centroid == pytest.approx(expected, abs=0.02 * geometry.bin_spacing)


@EVERY
def test_projector_and_its_autograd_backprojection_are_adjoint(geometry):
    torch.manual_seed(0)
    x = torch.rand(len(ANGLES), 32, 32, dtype=torch.float64, requires_grad=True)
    y = torch.rand(len(ANGLES), geometry.n_bins, dtype=torch.float64)
    ax = project(x, torch.tensor(ANGLES), geometry, 1.0, bin_samples=2)
    (aty,) = torch.autograd.grad(ax, x, y)
    lhs, rhs = float((ax * y).sum().detach()), float((x * aty).sum().detach())
    assert lhs == pytest.approx(rhs, rel=1e-12)
    assert abs(lhs) > 1.0


def test_distant_source_tends_to_parallel_beam():
    image = torch.tensor(ellipse_image(ImageGrid(64)))
    parallel = project(image, torch.tensor(ANGLES), ParallelGeometry(96, 1 / 64), 1.0)
    for shape in ("flat", "curved"):
        far = FanGeometry(96, 1 / 64, source_distance=1e6, detector_distance=1e-6, detector_shape=shape)
        fan = project(image, torch.tensor(ANGLES), far, 1.0)
        assert rel_l2(fan.numpy(), parallel.numpy()) < 1e-5


@pytest.mark.parametrize(
    "keys, message",
    [
        (dict(source_distance=2.0, detector_distance=-1.0), r"^detector_distance must be > 0, got -1\.0$"),
        (dict(source_distance=0.0, detector_distance=1.0), r"^source_distance must be > 0"),
        (dict(source_distance=2.0, detector_distance=1.0, detector_shape="round"),
         r"^detector_shape must be 'flat' or 'curved', got 'round'$"),
        (dict(source_distance=2.0), r"^detector_distance must be given with source_distance"),
        (dict(detector_distance=1.0), r"^detector_distance is a fan-beam key: it needs source_distance"),
        (dict(detector_offset=math.nan), r"^detector_offset must be a finite number"),
        (dict(source_distance=1.0, detector_distance=0.01, detector_shape="curved"), r"curved detector's fan angles"),
    ],
)
def test_invalid_geometry_names_the_key(keys, message):
    with pytest.raises(ValueError, match=message):
        make_geometry(64, 0.05, **keys)


def test_scanner_builds_the_geometry_and_prefixes_its_errors():
    scanner = Scanner(n_bins=8, bin_spacing=0.1, source_distance=2.0, detector_distance=1.0, detector_offset=0.05)
    assert scanner.geometry == FanGeometry(8, 0.1, 2.0, 1.0, "flat", 0.05)
    np.testing.assert_allclose(scanner.bin_positions, (np.arange(8) - 3.5) * 0.1 + 0.05)
    with pytest.raises(ValueError, match=r"^scanner\.detector_distance must be > 0"):
        Scanner(source_distance=2.0, detector_distance=-1.0)


def test_projector_refuses_a_source_inside_the_image():
    with pytest.raises(ValueError, match="source_distance must exceed the image's half-diagonal"):
        project(torch.zeros(8, 8), torch.zeros(1), FanGeometry(8, 0.2, 0.6, 1.0), 1.0)


def test_the_geometry_says_whether_its_rays_are_parallel_and_where_its_source_is():
    """Operators ask the geometry, never its type: parallel rays, and a source outside a radius."""
    parallel, fan = ParallelGeometry(8, 0.1, 0.05), FanGeometry(8, 0.1, 2.0, 1.0)
    assert parallel.is_parallel and not fan.is_parallel
    parallel.check_source_outside(1e9, "a disc")
    fan.check_source_outside(1.99, "a disc")
    with pytest.raises(ValueError, match=r"^source_distance must exceed a disc 2 \(.*\), got 2.0$"):
        fan.check_source_outside(2.0, "a disc")


def test_ellipse_list_is_off_centre():
    # The chord tests above would miss a mirrored convention for a centred, symmetric scene.
    assert all(abs(cx) + abs(cy) > 0.05 for cx, cy, *_ in ELLIPSES)
    assert ellipse_chords(np.zeros((1, 2)), np.array([[0.0, 1.0]]), ELLIPSES).shape == (1,)


def test_subsets_and_unit_changes_keep_the_geometry():
    from nct.acquisition.sinogram import Sinogram
    from nct.fit.problem import subset
    from nct.fit.units import Units

    geometry = GEOMETRIES["fan-curved-offset"]
    sino = Sinogram(np.ones((4, geometry.n_bins), np.float32), np.arange(4.0), np.arange(4.0), geometry)
    assert subset(sino, np.array([0, 2])).geometry == geometry
    halved = Units(2.0).sinogram(sino).geometry
    assert halved == FanGeometry(144, 0.00625, 1.0, 0.5, "curved", -0.05)
    assert geometry.scaled(0.5) == halved
