"""The sinogram file: round trip, and one clear error per kind of bad file.

The sinogram file's geometry keys: fan beam, detector shape and offset round-trip; bad values name the key.

Raw data: transmission counts with flat and dark fields, and TIFF stacks with a sidecar, load to the
line integrals they encode; bad raw input ends in one line naming the key.

Inputs a user expects to work (issue 28 item 5): float64 and integer data read as float32 (a cast that
loses detail warns), a transposed sinogram and a directory are named as such.
"""

from __future__ import annotations

import json
import re
from dataclasses import replace

import numpy as np
import pytest
import tifffile

from nct.acquisition.geometry import ParallelGeometry
from nct.acquisition.io import load_sinogram, save_sinogram
from nct.acquisition.scanner import ImageGrid, Scanner
from nct.acquisition.sinogram import Sinogram, Truth
from nct.errors import InputError
from nct.fit.units import Units
from nct.physics.fbp import fbp_frames
from nct.run.job import run_job
from nct.scenes.phantoms import StaticConf, build_phantom
from nct.scenes.simulate import simulate
from tests.conftest import GEOMETRIES, closed_form_sinogram


def make_sino(with_truth: bool = True) -> Sinogram:
    rng = np.random.default_rng(0)
    truth = Truth(rng.random((3, 8, 8), dtype=np.float32), np.array([0.0, 0.1, 0.2]), 1.0, 0.5) if with_truth else None
    return Sinogram(rng.random((10, 6), dtype=np.float32), np.linspace(0, np.pi, 10), np.linspace(0, 0.2, 10),
                    ParallelGeometry(6, 0.1), truth)


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
    assert r.geometry == s.geometry and r.truth.extent == 1.0 and r.truth.level == 0.5
    assert r.i0 is None and r.truth.levels == ()
    with_levels = replace(s, truth=replace(s.truth, levels=(0.5, 1.25)))
    save_sinogram(tmp_path / "l.npz", with_levels)
    assert load_sinogram(tmp_path / "l.npz").truth.levels == (0.5, 1.25)


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


def test_not_a_file_or_a_directory_named_as_such(tmp_path, nct):
    with pytest.raises(InputError, match="no such file"):
        load_sinogram(tmp_path / "missing.npz")
    (tmp_path / "junk.npz").write_text("not a zip")
    with pytest.raises(InputError, match="not a readable .npz"):
        load_sinogram(tmp_path / "junk.npz")
    folder = tmp_path / "scans"
    folder.mkdir()
    with pytest.raises(InputError, match=r"^data\.path: .*scans is a directory, not a file: .*no \.npz or \.tif"):
        load_sinogram(folder)
    for name in ("b.tif", "a.npz", "notes.txt"):
        (folder / name).write_text("")
    listed = f"data.path: {folder} is a directory, not a file: name a sinogram file in it (it holds a.npz, b.tif)"
    code, out, err = nct("debug=tiny", "logger=none", "method=fbp", "data=file", f"data.path={folder}")
    assert (code, err) == (2, f"nct: error: {listed}\n") and "reading" in out and "Traceback" not in out
    for i in range(6):
        (folder / f"scan{i}.npz").write_text("")
    with pytest.raises(InputError, match=r"\(it holds 8 \.npz/\.tif files\)$"):
        load_sinogram(folder)
    tifffile.imwrite(tmp_path / "scan.tif", np.ones((4, 4), np.float32))
    with pytest.raises(InputError, match=r"^data\.sidecar: .*scans is a directory"):
        load_sinogram(tmp_path / "scan.tif", folder)


@pytest.mark.parametrize("dtype", [np.float64, np.int16, np.uint16, np.int64])
def test_float64_and_integer_data_are_read_as_float32_without_a_warning(tmp_path, caplog, dtype):
    """numpy's default float64, integers (a 16-bit TIFF, a scaled sinogram) and integer times and
    angles load as the float32 the method works in; exact or near-exact casts stay silent."""
    a = good_arrays()
    values = (a["sinogram"] * 1000).astype(dtype)
    a.update(sinogram=values, times=np.arange(10), angles=np.arange(10) * 18, angles_unit=np.str_("deg"))
    with caplog.at_level("WARNING"):
        sino = load_sinogram(write(tmp_path / "cast.npz", **a))
        tifffile.imwrite(tmp_path / "cast.tif", values)
        np.savez(tmp_path / "cast_side.npz", **{k: v for k, v in a.items() if k != "sinogram"})
        stack = load_sinogram(tmp_path / "cast.tif", tmp_path / "cast_side.npz")
    assert sino.values.dtype == stack.values.dtype == np.float32 and caplog.records == []
    for loaded in (sino, stack):
        np.testing.assert_array_equal(loaded.values, values.astype(np.float32))


def test_a_cast_to_float32_that_loses_detail_warns_in_one_line(tmp_path, caplog):
    """Values 1e5 above a range of ~1 round by up to 2^-24 x 1e5 = 0.004 in float32: above 1e-6 of the range."""
    a = good_arrays()
    a.update(sinogram=a["sinogram"].astype(np.float64) + 1e5)
    with caplog.at_level("WARNING"):
        assert load_sinogram(write(tmp_path / "offset.npz", **a)).values.dtype == np.float32
    (record,) = caplog.records
    assert record.levelname == "WARNING" and "\n" not in record.getMessage()
    assert "key 'sinogram': casting float64 to float32" in record.getMessage()


@pytest.mark.parametrize("key", ["sinogram", "counts"])
def test_a_transposed_sinogram_is_named_as_such(tmp_path, nct, key):
    a = good_arrays()
    a[key] = a.pop("sinogram").T.copy()
    if key == "counts":
        a.update(counts=np.exp(-a["counts"]), flat=np.float64(1.0))
    path = write(tmp_path / "transposed.npz", **a)
    expected = (f"{path}: key '{key}': the sinogram looks transposed: got [6, 10], expected [n_views=10, n_bins=6] "
                "(angles and times hold 10 views)")
    with pytest.raises(InputError, match=re.escape(expected) + "$"):
        load_sinogram(path)
    code, out, err = nct("debug=tiny", "logger=none", "method=fbp", "data=file", f"data.path={path}")
    assert (code, err) == (2, f"nct: error: {expected}\n") and "Traceback" not in out  # out: the progress lines


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


def write_geometry(path, geometry, **changes) -> None:
    """A valid file of ``geometry`` (analytic ellipses, 12 views) with keys changed (None: removed)."""
    angles = np.linspace(0, 2 * np.pi, 12, endpoint=False)
    values = closed_form_sinogram(geometry, angles).astype(np.float32)
    save_sinogram(path, Sinogram(values, angles, np.linspace(0, 0.25, 12), geometry))
    with np.load(path) as data:
        arrays = dict(data)
    arrays.update({k: v for k, v in changes.items() if v is not None})
    for key in [k for k, v in changes.items() if v is None]:
        del arrays[key]
    np.savez(path, **arrays)


@pytest.mark.parametrize("geometry", GEOMETRIES.values(), ids=GEOMETRIES.keys())
def test_geometry_round_trips(tmp_path, geometry):
    write_geometry(tmp_path / "s.npz", geometry)
    sino = load_sinogram(tmp_path / "s.npz")
    assert sino.geometry == geometry


def test_a_file_without_geometry_keys_is_centred_parallel_beam(tmp_path):
    write_geometry(tmp_path / "s.npz", GEOMETRIES["parallel"], detector_offset=None)
    assert load_sinogram(tmp_path / "s.npz").geometry == ParallelGeometry(96, 1 / 64)


def test_flat_is_the_default_detector_shape(tmp_path):
    write_geometry(tmp_path / "s.npz", GEOMETRIES["fan-curved"], detector_shape=None)
    assert load_sinogram(tmp_path / "s.npz").geometry.detector_shape == "flat"


@pytest.mark.parametrize(
    "geometry, changes, message",
    [
        ("fan-flat", dict(detector_distance=np.float64(-1.0)), r"key 'detector_distance': expected a finite positive"),
        ("fan-flat", dict(source_distance=np.float64(0.0)), r"key 'source_distance': expected a finite positive"),
        ("fan-flat", dict(detector_distance=None), r"detector_distance must be given with source_distance"),
        ("fan-flat", dict(detector_shape=np.str_("round")), r"key 'detector_shape': expected 'flat' or 'curved'"),
        ("parallel", dict(detector_distance=np.float64(1.0)), r"detector_distance is a fan-beam key"),
        ("parallel", dict(detector_offset=np.float64(np.inf)), r"key 'detector_offset': expected"),
        ("fan-flat", dict(source_distance=np.str_("far")), r"key 'source_distance': expected a real scalar"),
    ],
)
def test_bad_geometry_keys_end_with_one_line_naming_the_key(tmp_path, geometry, changes, message):
    write_geometry(tmp_path / "s.npz", GEOMETRIES[geometry], **changes)
    with pytest.raises(InputError, match=message) as caught:
        load_sinogram(tmp_path / "s.npz")
    assert "\n" not in str(caught.value)


def test_fan_beam_file_runs_through_the_pipeline(tiny_cfg, run_dir, tmp_path):
    geometry = GEOMETRIES["fan-flat-offset"]
    scanner = Scanner(360, 1.0, 0.25, **{"n_bins": geometry.n_bins, **geometry.keys()})
    phantom = build_phantom(StaticConf(), scanner.rotation_time)
    sino = simulate(phantom, scanner, ImageGrid(64), np.array([0.125]), None, np.random.default_rng(0))
    save_sinogram(tmp_path / "fan.npz", sino)
    run_job(tiny_cfg("method=fbp", "data=file", f"data.path={tmp_path / 'fan.npz'}", "fbp.window_deg=360",
                     "logger=none", "export.gif=false", "export.tiff=false", "export.png=false"), run_dir)
    assert json.loads((run_dir / "metrics.json").read_text())["fbp"]["median_dice"] >= 0.98
    assert load_sinogram(run_dir / "sinogram.npz").geometry == geometry


GEOMETRY = GEOMETRIES["fan-flat-offset"]
N_VIEWS = 90
I0 = 5e4


def line_integrals() -> Sinogram:
    """The static ellipse pair's closed-form sinogram, one full turn."""
    angles = np.linspace(0, 2 * np.pi, N_VIEWS, endpoint=False)
    values = closed_form_sinogram(GEOMETRY, angles).astype(np.float32)
    return Sinogram(values, angles, np.linspace(0, 0.25, N_VIEWS), GEOMETRY)


def keys_without_values(sino: Sinogram) -> dict[str, np.ndarray]:
    """The file's keys other than ``sinogram`` (what a raw file or a TIFF sidecar holds)."""
    return {"angles": sino.angles, "times": sino.times, **{k: np.asarray(v) for k, v in GEOMETRY.keys().items()}}


def dark_and_flat() -> tuple[np.ndarray, np.ndarray]:
    """A dark field per bin and a flat field per view and bin (the source drifting over the scan)."""
    bins = np.arange(GEOMETRY.n_bins)
    dark = 100 + 20 * np.sin(bins / 7.0)
    drift = 1 + 0.05 * np.cos(np.linspace(0, 3, N_VIEWS))[:, None]
    return dark, dark + I0 * drift * (1 + 0.1 * np.cos(bins / 11.0))


def raw_file(path, sino: Sinogram, with_dark: bool, **changes):
    """``counts = dark + (flat - dark) exp(-p)`` of ``sino``'s line integrals p, written to ``path``."""
    p = sino.values.astype(np.float64)
    dark, flat = dark_and_flat() if with_dark else (np.zeros(()), np.float64(I0))
    arrays = keys_without_values(sino) | {"counts": dark + (flat - dark) * np.exp(-p), "flat": flat}
    if with_dark:
        arrays["dark"] = dark
    arrays.update(changes)
    np.savez(path, **arrays)
    return path


@pytest.mark.parametrize("with_dark", [False, True], ids=["flat-only", "flat-and-dark"])
def test_counts_load_to_the_line_integrals_and_the_same_fbp(tmp_path, with_dark):
    sino = line_integrals()
    raw = load_sinogram(raw_file(tmp_path / "raw.npz", sino, with_dark))
    np.testing.assert_allclose(raw.values, sino.values, rtol=1e-6, atol=1e-7)
    assert raw.geometry == GEOMETRY and sino.i0 is None
    expected_i0 = np.mean(np.subtract(*dark_and_flat()[::-1])) if with_dark else I0
    assert raw.i0 == pytest.approx(expected_i0, rel=1e-12)
    grid, times = ImageGrid(48), np.array([0.125])
    reference = fbp_frames(sino, grid, times, 360.0)
    np.testing.assert_allclose(fbp_frames(raw, grid, times, 360.0), reference, atol=1e-5 * reference.max())


def test_i0_is_kept_by_the_written_file_and_the_change_of_units(tmp_path):
    raw = load_sinogram(raw_file(tmp_path / "raw.npz", line_integrals(), True))
    assert Units(2.0, 3.0).sinogram(raw).i0 == raw.i0  # photons per ray: no length or intensity unit
    save_sinogram(tmp_path / "written.npz", raw)
    assert load_sinogram(tmp_path / "written.npz").i0 == pytest.approx(raw.i0, rel=1e-15)


def test_attenuation_keeps_the_transmission_through_units_and_files(tmp_path):
    """−log of normalised counts transmits exp(−p): k = 1; in other units k·p is unchanged."""
    raw = load_sinogram(raw_file(tmp_path / "raw.npz", line_integrals(), True))
    assert raw.attenuation == 1.0
    method = Units(2.0, 3.0).sinogram(raw)
    np.testing.assert_allclose(method.attenuation * method.values, raw.values, rtol=1e-6)
    save_sinogram(tmp_path / "written.npz", method)
    assert load_sinogram(tmp_path / "written.npz").attenuation == pytest.approx(6.0, rel=1e-15)


def test_a_ray_that_records_nothing_is_clipped_not_infinite(tmp_path):
    sino = line_integrals()
    counts = I0 * np.exp(-sino.values.astype(np.float64))
    counts[3, 40] = 0.0
    raw = load_sinogram(raw_file(tmp_path / "raw.npz", sino, False, counts=counts))
    assert raw.values[3, 40] == pytest.approx(-np.log(1e-6), rel=1e-6)


def test_tiff_stacks_round_trip(tmp_path):
    sino = line_integrals()
    # Line integrals: a float32 TIFF; the sidecar holds every other key, angles in degrees here.
    tifffile.imwrite(tmp_path / "scan.tif", sino.values)
    np.savez(tmp_path / "scan.npz", **keys_without_values(sino) | {"angles": np.rad2deg(sino.angles),
                                                                   "angles_unit": np.str_("deg")})
    loaded = load_sinogram(tmp_path / "scan.tif")
    np.testing.assert_array_equal(loaded.values, sino.values)
    np.testing.assert_allclose(loaded.angles, sino.angles, rtol=1e-12)
    assert loaded.geometry == GEOMETRY
    # Raw counts: a 16-bit TIFF; the sidecar (named explicitly) has the flat field, so the stack is counts.
    counts = np.round(I0 * np.exp(-sino.values.astype(np.float64))).astype(np.uint16)
    tifffile.imwrite(tmp_path / "counts.tiff", counts)
    np.savez(tmp_path / "meta.npz", **keys_without_values(sino) | {"flat": np.float64(I0)})
    raw = load_sinogram(tmp_path / "counts.tiff", tmp_path / "meta.npz")
    # Rounding to whole counts moves -log(I/I0) by at most 0.5 / counts (counts >= 2.9e4 here).
    np.testing.assert_allclose(raw.values, sino.values, atol=2e-5)
    assert raw.i0 == I0


def test_a_tiff_stack_runs_through_the_pipeline(tiny_cfg, run_dir, tmp_path):
    sino = line_integrals()
    tifffile.imwrite(tmp_path / "scan.tif", sino.values)
    np.savez(tmp_path / "side.npz", **keys_without_values(sino))
    run_job(tiny_cfg("method=fbp", "data=file", f"data.path={tmp_path / 'scan.tif'}",
                     f"data.sidecar={tmp_path / 'side.npz'}", "fbp.window_deg=360", "logger=none",
                     "export.gif=false", "export.tiff=false", "export.png=false"), run_dir)
    assert json.loads((run_dir / "status.json").read_text())["status"] == "ok"
    np.testing.assert_array_equal(load_sinogram(run_dir / "sinogram.npz").values, sino.values)


@pytest.mark.parametrize("with_dark, changes, message", [
    (True, dict(dark=dark_and_flat()[1] + 1), r"key 'flat': expected flat > dark in every bin"),
    (False, dict(flat=np.float64(0)), r"key 'flat': expected flat > dark"),
    (False, dict(counts=-np.ones((N_VIEWS, GEOMETRY.n_bins))), r"key 'counts': expected counts >= 0"),
    (True, dict(flat=np.ones(GEOMETRY.n_bins + 1)), r"key 'flat': expected a scalar, \[n_bins\] or"),
    (True, dict(dark=np.ones((2, GEOMETRY.n_bins))), r"key 'dark': expected a scalar, \[n_bins\] or"),
    (False, dict(sinogram=np.ones((N_VIEWS, GEOMETRY.n_bins), np.float32)), r"key 'sinogram': .* got both"),
    (False, dict(flat=None), r"key 'flat': expected present with 'counts'"),
    (False, dict(i0=np.float64(3.0)), r"key 'i0': expected absent with 'counts'"),
    (False, dict(flat=np.float64(np.nan)), r"key 'flat': expected finite values"),
    (False, dict(counts=None), r"key 'flat': expected only with 'counts'"),
    (False, dict(counts=np.full((N_VIEWS, GEOMETRY.n_bins), I0)), r"key 'counts': expected some non-zero line"),
])
def test_bad_raw_input_names_the_key_in_one_line(tmp_path, with_dark, changes, message):
    sino = line_integrals()
    removed = [k for k, v in changes.items() if v is None]
    path = raw_file(tmp_path / "raw.npz", sino, with_dark, **{k: v for k, v in changes.items() if v is not None})
    if removed:
        with np.load(path) as data:
            arrays = {k: data[k] for k in data.files if k not in removed}
        if "counts" in removed:
            arrays["sinogram"] = sino.values
        np.savez(path, **arrays)
    with pytest.raises(InputError, match=message) as caught:
        load_sinogram(path)
    assert "\n" not in str(caught.value)


def test_bad_tiff_input_names_the_setting_or_key(tmp_path):
    sino = line_integrals()
    tifffile.imwrite(tmp_path / "scan.tif", sino.values)
    with pytest.raises(InputError, match=r"^data\.sidecar: no such file: .*scan\.npz"):
        load_sinogram(tmp_path / "scan.tif")
    np.savez(tmp_path / "scan.npz", **keys_without_values(sino) | {"sinogram": sino.values})
    with pytest.raises(InputError, match=r"key 'sinogram': expected no data in the sidecar"):
        load_sinogram(tmp_path / "scan.tif")
    np.savez(tmp_path / "plain.npz", sinogram=sino.values, **keys_without_values(sino))
    with pytest.raises(InputError, match=r"^data\.sidecar: only a TIFF stack"):
        load_sinogram(tmp_path / "plain.npz", tmp_path / "scan.npz")
    (tmp_path / "junk.tif").write_text("not a tiff")
    with pytest.raises(InputError, match=r"^data\.path: .*junk\.tif is not a readable TIFF"):
        load_sinogram(tmp_path / "junk.tif")
