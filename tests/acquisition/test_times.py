"""A file's view times: read in the unit the user states (data.times_unit), and a gantry turn that no
scanner makes refused, one that only a lab scanner makes warned of, naming ``times`` and the fix."""

from __future__ import annotations

import numpy as np
import pytest

from nct.acquisition.geometry import ParallelGeometry
from nct.acquisition.io import load_sinogram, save_sinogram
from nct.acquisition.sinogram import Sinogram, Truth
from nct.acquisition.times import in_seconds, rotation_time, slow_rotation_warning
from nct.errors import InputError

ANGLES = np.linspace(0, np.pi, 10)  # half a turn


def test_rotation_time_is_the_duration_over_the_turns_spanned():
    assert rotation_time(ANGLES, np.linspace(0, 0.125, 10)) == pytest.approx(0.25)


def test_milliseconds_are_read_as_seconds_only_when_stated():
    ms = np.linspace(0, 125, 10)
    np.testing.assert_allclose(in_seconds(ANGLES, ms, "ms", "scan.npz"), ms / 1e3)
    np.testing.assert_array_equal(in_seconds(ANGLES, ms, None, "scan.npz"), ms)
    assert slow_rotation_warning(ANGLES, ms, None)[0].startswith("times: a gantry turn every 250 s")
    assert "data.times_unit=ms" in slow_rotation_warning(ANGLES, ms, None)[0]
    assert slow_rotation_warning(ANGLES, ms, "s") == []  # stated: a lab scanner's slow turn
    assert slow_rotation_warning(ANGLES, ms / 1e3, None) == []


def test_a_turn_faster_than_a_millisecond_is_refused_naming_times_and_the_setting():
    seconds = np.linspace(0, 0.125, 10)
    with pytest.raises(InputError, match=r"^scan.npz: key 'times': a gantry turn every 0.25 ms with the times in "
                                         r"ms \(data.times_unit=ms\), faster than any scanner \(1 ms\): set "
                                         r"data.times_unit \(s or ms\)"):
        in_seconds(ANGLES, seconds, "ms", "scan.npz")
    with pytest.raises(InputError, match=r"in seconds \(data.times_unit unset\)"):
        in_seconds(ANGLES, seconds / 1e3, None, "scan.npz")


def test_a_file_in_milliseconds_loads_as_the_same_scan_in_seconds(tmp_path):
    rng = np.random.default_rng(0)
    truth = Truth(rng.random((3, 8, 8), dtype=np.float32), np.array([0.0, 0.1, 0.2]), 1.0, 0.5)
    sino = Sinogram(rng.random((10, 6), dtype=np.float32), ANGLES, np.linspace(0, 0.2, 10), ParallelGeometry(6, 0.1),
                    truth)
    save_sinogram(tmp_path / "s.npz", sino)
    with np.load(tmp_path / "s.npz") as f:
        arrays = dict(f) | {"times": f["times"] * 1e3, "truth_times": f["truth_times"] * 1e3}
    np.savez(tmp_path / "ms.npz", **arrays)
    seconds, ms = load_sinogram(tmp_path / "s.npz"), load_sinogram(tmp_path / "ms.npz", times_unit="ms")
    np.testing.assert_allclose(ms.times, seconds.times, rtol=1e-12)
    np.testing.assert_allclose(ms.truth.times, seconds.truth.times, rtol=1e-12)
