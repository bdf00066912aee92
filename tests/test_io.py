"""The sinogram file: round trip, and one clear error per kind of bad file."""

from dataclasses import replace

import numpy as np
import pytest

from nct.errors import InputError
from nct.acquisition.io import load_sinogram, save_sinogram
from nct.acquisition.sinogram import Sinogram, Truth


def make_sino(with_truth: bool = True) -> Sinogram:
    rng = np.random.default_rng(0)
    truth = Truth(rng.random((3, 8, 8), dtype=np.float32), np.array([0.0, 0.1, 0.2]), 1.0, 0.5) if with_truth else None
    return Sinogram(rng.random((10, 6), dtype=np.float32), np.linspace(0, np.pi, 10), np.linspace(0, 0.2, 10),
                    0.1, None, truth)


def write(path, **arrays):
    np.savez(path, **arrays)
    return path


def good_arrays() -> dict:
    s = make_sino()
    return {"sinogram": s.values, "angles": s.angles, "times": s.times, "bin_spacing": np.float64(0.1)}


def test_round_trip(tmp_path):
    s = make_sino()
    save_sinogram(tmp_path / "s.npz", s)
    r = load_sinogram(tmp_path / "s.npz")
    np.testing.assert_array_equal(r.values, s.values)
    np.testing.assert_array_equal(r.angles, s.angles)
    np.testing.assert_array_equal(r.truth.frames, s.truth.frames)
    assert r.bin_spacing == 0.1 and r.truth.extent == 1.0 and r.truth.level == 0.5
    assert r.i0 is None


def test_i0_round_trip(tmp_path):
    save_sinogram(tmp_path / "s.npz", replace(make_sino(), i0=2.5e4))
    assert load_sinogram(tmp_path / "s.npz").i0 == 2.5e4


def test_truth_level_defaults_to_half_peak(tmp_path):
    a = good_arrays() | {"truth": np.full((2, 4, 4), 2.0, np.float32), "truth_times": np.array([0.0, 1.0]),
                         "truth_extent": 1.0}
    assert load_sinogram(write(tmp_path / "t.npz", **a)).truth.level == pytest.approx(1.0)


@pytest.mark.parametrize(
    "change, key",
    [
        (lambda a: a.pop("angles"), "'angles'"),
        (lambda a: a.update(sinogram=a["sinogram"].astype(np.float64)), "'sinogram'"),
        (lambda a: a.update(sinogram=a["sinogram"][0]), "'sinogram'"),
        (lambda a: a["sinogram"].__setitem__((2, 3), np.nan), "'sinogram'"),
        (lambda a: a.update(times=a["times"][::-1].copy()), "'times'"),
        (lambda a: a.update(angles=a["angles"][:5]), "'angles'"),
        (lambda a: a.update(angles=a["angles"] + np.inf), "'angles'"),
        (lambda a: a.update(bin_spacing=np.float64(-1.0)), "'bin_spacing'"),
        (lambda a: a.update(bin_spacing=np.array(["x"])), "'bin_spacing'"),
        (lambda a: a.update(extra=np.zeros(3)), "'extra'"),
        (lambda a: a.update(truth=np.zeros((2, 4, 4), np.float32)), "'truth_times'"),
        (lambda a: a.update(truth_times=np.zeros(2)), "'truth'"),
        (lambda a: a.update(i0=np.float64(0.0)), "'i0'"),
        # implausible content (issue 9 item 7)
        (lambda a: a.update(angles=np.rad2deg(a["angles"]) * 2), "'angles'"),  # degrees, one rotation
        (lambda a: a.update(angles=np.zeros(10)), "'angles'"),
        (lambda a: a.update(angles_unit=np.array("grad")), "'angles_unit'"),
        (lambda a: a.update(sinogram=np.zeros((10, 6), np.float32)), "'sinogram'"),
        (lambda a: a.update(sinogram=-a["sinogram"]), "'sinogram'"),
        (lambda a: a.update(sinogram=a["sinogram"] * np.float32(1e30)), "'sinogram'"),
        (lambda a: a.update(times=np.full(10, 0.3)), "'times'"),
        (lambda a: a.update(times=np.array([object()] * 10)), "'times'"),
    ],
)
def test_bad_files_name_the_key(tmp_path, change, key):
    a = good_arrays()
    change(a)
    with pytest.raises(InputError) as info:
        load_sinogram(write(tmp_path / "bad.npz", **a))
    message = str(info.value)
    assert key in message and "\n" not in message


def test_not_a_file(tmp_path):
    with pytest.raises(InputError, match="no such file"):
        load_sinogram(tmp_path / "missing.npz")
    (tmp_path / "junk.npz").write_text("not a zip")
    with pytest.raises(InputError, match="not a readable .npz"):
        load_sinogram(tmp_path / "junk.npz")


def test_degrees_accepted_when_the_file_says_so(tmp_path):
    a = good_arrays()
    a.update(angles=np.rad2deg(a["angles"]) * 2, angles_unit=np.array("deg"))
    np.testing.assert_allclose(load_sinogram(write(tmp_path / "deg.npz", **a)).angles, good_arrays()["angles"] * 2)
    # a long scan in radians passes once the unit is stated
    a = good_arrays() | {"angles": np.linspace(0, 40 * np.pi * 2, 10), "angles_unit": np.array("rad")}
    assert load_sinogram(write(tmp_path / "long.npz", **a)).angles[-1] == pytest.approx(80 * np.pi)


def test_noisy_data_dipping_below_zero_is_accepted(tmp_path):
    a = good_arrays()
    a["sinogram"] = a["sinogram"] - np.float32(0.3)  # some negatives, mostly positive
    assert load_sinogram(write(tmp_path / "noisy.npz", **a)).values.min() < 0
