"""The truth-free geometry check: the detector offset the views' first moments call for, and the
warning when a file's detector_offset is wrong (which the held-out misfits miss)."""

from dataclasses import replace

import numpy as np
import pytest

from nct.acquisition.geometry import ParallelGeometry
from nct.acquisition.scanner import ImageGrid, Scanner
from nct.run.conf import SuspectConf
from nct.run.consistency import check_geometry, geometry_warnings
from nct.scenes.phantoms import ComposedConf, build_phantom
from nct.scenes.simulate import simulate
from tests.conftest import moving_disc, still

GRID = ImageGrid(32)
FAN = {"source_distance": 2.0, "detector_distance": 2.0, "detector_shape": "flat"}


def scan(objects, noise_i0: float | None = None, **fan):
    """``objects`` (phantoms.EllipseConf) scanned over one rotation: 90 views of 48 bins (fan:
    spanning the fan through the field), noiseless unless ``noise_i0``."""
    spacing = 2.1 / 48 if fan else 1 / 48
    scanner = Scanner(views_per_rotation=90, rotations=1.0, rotation_time=0.25, n_bins=48,
                      bin_spacing=spacing, **fan)
    phantom = build_phantom(ComposedConf(objects=objects), scanner.rotation_time)
    return simulate(phantom, scanner, GRID, scanner.frame_times(3), noise_i0, np.random.default_rng(0))


STILL = [still(0.12, -0.06, 0.2, 0.12, 1.0), still(-0.15, 0.1, 0.08, 0.06, 0.5)]


def misread(sino, offset_bins: float = 0.0, as_parallel: bool = False):
    """``sino`` as a file with a wrong geometry gives it: detector_offset ``offset_bins`` bins off,
    or a fan beam's keys dropped (read as parallel beam)."""
    g = sino.geometry
    geometry = (ParallelGeometry(g.n_bins, g.bin_spacing, g.detector_offset) if as_parallel
                else replace(g, detector_offset=g.detector_offset + offset_bins * g.bin_spacing))
    return replace(sino, geometry=geometry)


def warned(sino) -> list[str]:
    """The geometry warnings on ``sino`` at the default limits."""
    return geometry_warnings(check_geometry(sino), sino, SuspectConf())


@pytest.mark.parametrize("fan", [{}, FAN], ids=["parallel", "fan"])
def test_a_wrong_detector_offset_is_measured_and_named(fan):
    sino = scan(STILL, **fan)
    wrong = misread(sino, 3.0)
    assert abs(check_geometry(sino).offset.bins) < 0.1 and not warned(sino)
    assert 2.0 < check_geometry(wrong).offset.bins < 3.5  # the views' centroids sit 3 bins off the file's axis
    (line,) = warned(wrong)
    assert line.startswith("suspect geometry") and "detector_offset" in line
    assert not geometry_warnings(check_geometry(wrong), wrong, SuspectConf(offset_bins=4.0))  # the config's limit


def test_a_noisy_correct_scan_stays_quiet():
    assert not warned(scan(STILL, noise_i0=1e3))


def test_motion_as_fast_as_the_gantry_is_not_taken_for_an_offset():
    sino, _ = moving_disc()  # one rotation, the disc orbiting 60 deg: its motion could hide an offset
    for offset in (0.0, 3.0):
        assert check_geometry(misread(sino, offset)).offset.motion_bins > SuspectConf().offset_motion_bins
        assert not warned(misread(sino, offset))


def test_a_fan_beam_scan_read_as_parallel_is_named():
    sino = scan(STILL, **FAN)
    swing = check_geometry(misread(sino, as_parallel=True)).fan
    assert 3.0 < swing.nearest <= swing.radii < 5.0  # source to detector 4 = 3.9 field radii of the misread file
    (line,) = warned(misread(sino, as_parallel=True))
    assert "fan-beam scan read as parallel" in line
    assert check_geometry(sino).fan is None  # a fan file: its totals are not a parallel beam's

