"""A lone mover's axis from the views' second moments: read exactly off closed-form chords, held only
where the shape is elongated and rigid, and not read in fan beam; one turning part's among still ones,
read where it can be told from theirs."""

from __future__ import annotations

import math

import numpy as np
import pytest

from nct.acquisition.sinogram import Sinogram
from nct.moments.orientation import (
    ELONGATED,
    frame_coverage,
    orientation_path,
    second_moments,
    steady_turn,
    turning_part,
)
from tests.conftest import GEOMETRIES, closed_form_sinogram

VIEWS = 240


def turning(geometry, rate_deg: float, a=(0.3, 0.3), b=(0.1, 0.1), rotations: float = 1.0) -> tuple[Sinogram, np.ndarray]:
    """An ellipse (semi-axes ``a``, ``b`` from their first to their second value over the scan) turning
    ``rate_deg`` per rotation from 20 deg while its centre drifts, one view per instant, closed-form
    chords (conftest): the sinogram and its true axis at every view [V] (rad)."""
    angles = np.linspace(0, 2 * math.pi * rotations, round(VIEWS * rotations), endpoint=False)
    share = angles / angles[-1]
    axis = math.radians(20) + math.radians(rate_deg) * angles / (2 * math.pi)
    values = np.stack([closed_form_sinogram(geometry, angles[v:v + 1], (
        (0.1 * s, -0.05 + 0.05 * s, a[0] + (a[1] - a[0]) * s, b[0] + (b[1] - b[0]) * s, axis[v], 1.0),),
        sub_rays=4)[0] for v, s in enumerate(share)])
    return Sinogram(values.astype(np.float32), angles, angles / (2 * math.pi) * 0.25, geometry), axis


@pytest.mark.parametrize("name", ["parallel", "parallel-offset"])
def test_second_moments_are_the_ellipse_seen_along_the_detector(name):
    """A still uniform ellipse has moments a²/4 and b²/4 along its axes: each view's is eᵀΣe, plus the
    bins' own width²/12 (Sheppard's correction: a bin's value is its width's average), to 1.5 % (the
    chords' square-root edges over 13 bins across; a raw, uncentred moment is off by the centre's square)."""
    geometry = GEOMETRIES[name]
    sino, axis = turning(geometry, 0.0)
    rel = sino.angles - axis
    expected = 0.3**2 / 4 * np.cos(rel) ** 2 + 0.1**2 / 4 * np.sin(rel) ** 2 + geometry.bin_spacing**2 / 12
    assert np.abs(second_moments(sino) / expected - 1).max() < 0.015


@pytest.mark.parametrize("rate", [0.0, 100.0, -175.0])
def test_a_turning_bar_is_read_to_a_fraction_of_a_degree(rate):
    """The axis (mod 180 deg) at every view within 0.5 deg, the slower of the mirror answers, held."""
    sino, axis = turning(GEOMETRIES["parallel"], rate)
    found = orientation_path(sino)
    off = (found.at(sino.times) - axis + math.pi / 2) % math.pi - math.pi / 2
    assert np.degrees(np.abs(off)).max() < 0.5
    assert found.held and found.anisotropy / found.isotropic == pytest.approx(0.8, abs=0.01)  # (9 - 1) / (9 + 1)


@pytest.mark.parametrize("rate, coverage", [(100.0, 260.0), (-100.0, 460.0), (300.0, 60.0)])
def test_the_frame_is_seen_over_the_gantry_turn_less_the_objects(rate, coverage):
    """Over one rotation of the gantry the object's own frame is seen over 360 deg minus its own turn (within 2 deg)."""
    sino, _ = turning(GEOMETRIES["parallel"], rate)
    assert frame_coverage(sino, orientation_path(sino)) == pytest.approx(coverage * (VIEWS - 1) / VIEWS, abs=2.0)


def test_over_several_rotations():
    sino, axis = turning(GEOMETRIES["parallel"], 150.0, rotations=3.0)
    found = orientation_path(sino)
    off = (found.at(sino.times) - axis + math.pi / 2) % math.pi - math.pi / 2
    assert found.held and np.degrees(np.abs(off)).max() < 0.5


def test_a_disc_a_changing_shape_and_fan_beam_hold_no_axis():
    """A disc has no axis (B/A under ELONGATED); an ellipse that grows from 0.2 x 0.1 to 0.3 x 0.1 explains
    its moments by no rigid turn; a rebinned fan view mixes instants: None."""
    disc = orientation_path(turning(GEOMETRIES["parallel"], 100.0, a=(0.2, 0.2), b=(0.2, 0.2))[0])
    assert disc.anisotropy < ELONGATED * disc.isotropic and not disc.held
    growing = orientation_path(turning(GEOMETRIES["parallel"], 100.0, a=(0.2, 0.3))[0])
    assert not growing.held
    assert orientation_path(turning(GEOMETRIES["fan-flat"], 100.0)[0]) is None


def test_a_turning_part_beside_a_still_one_is_read_with_the_still_rest():
    """An ellipse turning 120 deg/rotation about its centre beside a larger still one (their centroid
    still): the five-term fit (a still quadratic form added) reads the turn within 1 deg/rotation; the
    lone shape's three terms do not."""
    geometry = GEOMETRIES["parallel"]
    angles = np.linspace(0, 2 * math.pi, VIEWS, endpoint=False)
    axis = math.radians(10) + math.radians(120) * angles / (2 * math.pi)
    values = np.stack([closed_form_sinogram(geometry, angles[v:v + 1], (
        (0.15, 0.0, 0.2, 0.07, axis[v], 1.0), (-0.2, 0.05, 0.25, 0.12, 0.4, 1.0)), sub_rays=4)[0]
        for v in range(VIEWS)])
    sino = Sinogram(values.astype(np.float32), angles, angles / (2 * math.pi) * 0.25, geometry)
    tau = angles / (2 * math.pi)
    rest, _, _ = steady_turn(angles, tau, second_moments(sino), still_rest=True)
    lone, _, _ = steady_turn(angles, tau, second_moments(sino))
    assert abs(math.degrees(rest) - 120) < 1 and abs(math.degrees(lone) - 120) > 5


def part_and_rest(rate_deg: float, drift: float = 0.0, rotations: float = 1.0) -> tuple[Sinogram, np.ndarray]:
    """An ellipse 0.25 x 0.08 turning ``rate_deg`` per rotation from 20 deg about (0.15, 0.05) beside a
    still one (0.12 x 0.08 at 30 deg, intensity 0.7, moving ``drift`` to the right over the scan):
    closed-form chords, one view per instant; the sinogram and the part's true axis [V] (rad)."""
    angles = np.linspace(0, 2 * math.pi * rotations, round(VIEWS * rotations), endpoint=False)
    share = angles / angles[-1]
    axis = math.radians(20) + math.radians(rate_deg) * angles / (2 * math.pi)
    values = np.stack([closed_form_sinogram(GEOMETRIES["parallel"], angles[v:v + 1], (
        (0.15, 0.05, 0.25, 0.08, axis[v], 1.0), (-0.25 + drift * s, -0.1, 0.12, 0.08, math.radians(30), 0.7)),
        sub_rays=4)[0] for v, s in enumerate(share)])
    return Sinogram(values.astype(np.float32), angles, angles / (2 * math.pi) * 0.25, GEOMETRIES["parallel"]), axis


@pytest.mark.parametrize("rate, rotations", [(170.0, 2.0), (-60.0, 1.0)])
def test_one_turning_part_is_read_among_still_ones(rate, rotations):
    """The part's axis within 1 deg at every view, held; the lone-shape model explains these views by no
    rigid turn (the still one's quadratic form beside it)."""
    sino, axis = part_and_rest(rate, rotations=rotations)
    found = turning_part(sino)
    off = (found.at(sino.times) - axis + math.pi / 2) % math.pi - math.pi / 2
    assert found.part and found.held and np.degrees(np.abs(off)).max() < 1.0
    assert not orientation_path(sino).held


@pytest.mark.parametrize("rate, drift", [(0.0, 0.0), (10.0, 0.0), (355.0, 0.0), (170.0, 0.1)])
def test_no_part_turn_where_it_cannot_be_told(rate, drift):
    """Still parts, a turn of 10 deg over the scan, one with the gantry (its terms constant) and a
    still object drifting by a tenth of the field (the whole centroid moves): none read, or none held
    (still parts: no turn explains their moments' spread, which is noise)."""
    found = turning_part(part_and_rest(rate, drift)[0])
    assert found is None or not found.held
