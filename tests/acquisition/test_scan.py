"""The Scan (acquisition/scan.py): arrays checked as a file's keys are, one grid and frame-time rule for
every way the data come."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from nct.acquisition.geometry import FanGeometry, ParallelGeometry
from nct.acquisition.io import save_sinogram
from nct.acquisition.scan import Scan, output_grid
from nct.acquisition.scanner import ImageGrid
from nct.acquisition.sinogram import Truth
from nct.errors import InputError
from tests.conftest import moving_disc


@pytest.fixture(scope="module")
def disc():
    """The moving disc of tests/conftest.py: its sinogram (with truth) and frame times."""
    return moving_disc()


def arrays(sino) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    return sino.values, sino.angles, sino.times


def test_arrays_give_the_scan_a_file_of_them_gives(disc, tmp_path):
    sino, _ = disc
    save_sinogram(tmp_path / "scan.npz", sino)
    from_file = Scan.from_file(tmp_path / "scan.npz")
    ours = Scan(*arrays(sino), bin_spacing=sino.geometry.bin_spacing, truth=sino.truth)
    for scan in (ours, from_file):
        np.testing.assert_array_equal(scan.sinogram.values, sino.values)
        np.testing.assert_array_equal(scan.sinogram.truth.frames, sino.truth.frames)
        assert scan.sinogram.geometry == sino.geometry and not scan.simulated
    assert ours.grid == from_file.grid == ImageGrid(32, 1.0)
    np.testing.assert_array_equal(ours.frame_times, from_file.frame_times)


def test_lists_ints_and_float64_just_work():
    angles = np.linspace(0, 2 * np.pi, 8, endpoint=False)
    values = [[0, 1, 2, 1, 0]] * 8  # ints in a list of lists
    scan = Scan(values, angles.tolist(), list(range(8)), bin_spacing=1, size=16, frames_per_rotation=2)
    assert scan.sinogram.values.dtype == np.float32 and scan.sinogram.times.dtype == np.float64
    assert scan.grid == ImageGrid(16, 5.0)  # the detector's reach: 5 bins of 1
    np.testing.assert_allclose(scan.frame_times, [1.75, 5.25])  # 8 views over 7/8 of a turn: 2 slots of 0..7 s


def test_times_in_milliseconds_are_seconds_inside():
    angles = np.linspace(0, 2 * np.pi, 8, endpoint=False)
    scan = Scan(np.ones((8, 4)), angles, np.arange(8) * 31.25, bin_spacing=0.25, times_unit="ms")
    np.testing.assert_allclose(scan.sinogram.times, np.arange(8) * 0.03125)
    assert scan.times_unit == "ms"


def test_a_fan_geometry_is_taken_whole():
    fan = FanGeometry(16, 0.1, source_distance=3.0, detector_distance=1.0, detector_shape="curved")
    angles = np.linspace(0, 2 * np.pi, 10, endpoint=False)
    scan = Scan(np.ones((10, 16)), angles, angles / (2 * np.pi) * 0.3, geometry=fan, size=8)
    assert scan.sinogram.geometry == fan
    assert math.isclose(scan.grid.extent, 2 * fan.field_radius)


def test_the_truth_sets_the_grid_and_times_whatever_the_size_asked(disc):
    sino, times = disc
    grid, frame_times = output_grid(sino, size=64, extent=3.0, frames_per_rotation=50)
    assert grid == ImageGrid(32, sino.truth.extent) and frame_times is sino.truth.times
    np.testing.assert_array_equal(frame_times, times)


@pytest.mark.parametrize("change, says", [
    ({"angles": np.zeros(5)}, "nct.Scan: key 'angles': expected length 8 (one per view/frame), got shape (5,)"),
    ({"sinogram": [[1, 2], [3]]}, "nct.Scan: sinogram: expected a numeric array"),
    ({"sinogram": np.ones((4, 8))}, "the sinogram looks transposed"),
    ({"times": np.arange(8)[::-1]}, "key 'times': expected non-decreasing times"),
    ({"bin_spacing": None}, "bin_spacing (the detector's bin width) or geometry is required"),
    ({"geometry": ParallelGeometry(4, 0.25)}, "give bin_spacing or geometry, not both"),
    ({"bin_spacing": None, "geometry": ParallelGeometry(5, 0.25)}, "geometry has 5 bins, the sinogram 4"),
    ({"bin_spacing": None, "geometry": "fan"}, "geometry must be a ParallelGeometry or FanGeometry"),
    ({"bin_spacing": -1.0}, "key 'bin_spacing': expected a finite positive number"),
    ({"size": 1}, "size must be a whole number >= 2"),
    ({"extent": 0.0}, "extent must be a finite number > 0"),
    ({"frames_per_rotation": 2.5}, "frames_per_rotation must be a whole number >= 1"),
    ({"times_unit": "min"}, "times_unit must be one of s, ms"),
    ({"truth": np.ones((1, 4, 4))}, "truth must be an nct.Truth"),
    ({"truth": Truth(np.ones((1, 4, 5)), np.zeros(1), 1.0, 0.5)}, "key 'truth': expected square frames"),
])
def test_bad_arrays_are_one_line_naming_the_argument(change, says):
    args = {"sinogram": np.ones((8, 4)), "angles": np.linspace(0, 2 * np.pi, 8, endpoint=False),
            "times": np.arange(8) * 0.03, "bin_spacing": 0.25} | change
    with pytest.raises(InputError) as err:
        Scan(args.pop("sinogram"), args.pop("angles"), args.pop("times"), **args)
    assert says in str(err.value) and "\n" not in str(err.value)


def test_a_file_and_its_i0_are_checked(disc, tmp_path):
    with pytest.raises(InputError, match="data.path: no such file"):
        Scan.from_file(tmp_path / "missing.npz")
    save_sinogram(tmp_path / "scan.npz", disc[0])
    with pytest.raises(InputError, match="i0 must be a finite number > 0"):
        Scan.from_file(tmp_path / "scan.npz", i0=-3.0)
    assert Scan.from_file(tmp_path / "scan.npz", i0=500).sinogram.i0 == 500.0


@pytest.mark.parametrize("fan", [False, True])
def test_a_fit_of_a_large_scan_reads_its_views_binned_onto_a_smaller_grid(fan):
    """optim.fit_size: bins averaged in groups of size // fit_size on the bins' mean positions (30 bins by 4: one
    left out at each edge), the counts that many times a bin's; a scan under twice fit_size is its own."""
    sino = moving_disc()[0]
    geometry = (FanGeometry(30, sino.geometry.bin_spacing, 3.0, 3.0, detector_offset=0.01) if fan
                else ParallelGeometry(30, sino.geometry.bin_spacing, detector_offset=0.01))
    values = np.random.default_rng(0).random((sino.n_views, 30)).astype(np.float32)
    scan = Scan.of(replace(sino, values=values, geometry=geometry, i0=100.0), ImageGrid(32, 1.0), np.array([0.1]))
    small = scan.to_fit(8)
    assert (small.grid.size, small.grid.extent, small.sinogram.n_bins, small.sinogram.i0) == (8, 1.0, 7, 400.0)
    assert small.truth is None and type(small.sinogram.geometry) is type(geometry) and list(small.frame_times) == [0.1]
    np.testing.assert_allclose(small.sinogram.values, values[:, 1:29].reshape(-1, 7, 4).mean(-1), rtol=1e-6)
    centres = geometry.bin_positions[1:29].reshape(7, 4).mean(-1)
    np.testing.assert_allclose(small.sinogram.geometry.bin_positions, centres, atol=1e-12)
    assert scan.to_fit(17) is scan and scan.to_fit(None) is scan and scan.to_fit(16).grid.size == 16
