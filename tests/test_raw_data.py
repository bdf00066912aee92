"""Raw data: transmission counts with flat and dark fields, and TIFF stacks with a sidecar, load to the
line integrals they encode; bad raw input ends in one line naming the key."""

from __future__ import annotations

import json

import numpy as np
import pytest
import tifffile
from geometry_cases import GEOMETRIES, closed_form_sinogram

from nct.errors import InputError
from nct.acquisition.io import load_sinogram, save_sinogram
from nct.method.normalise import Units
from nct.run.pipeline import run_job
from nct.physics.projector import fbp_frames
from nct.acquisition.scanner import ImageGrid
from nct.acquisition.sinogram import Sinogram

GEOMETRY = GEOMETRIES["fan-flat-offset"]
N_VIEWS = 90
I0 = 5e4


def line_integrals() -> Sinogram:
    """The static ellipse pair's closed-form sinogram, one full turn."""
    angles = np.linspace(0, 2 * np.pi, N_VIEWS, endpoint=False)
    values = closed_form_sinogram(GEOMETRY, angles).astype(np.float32)
    return Sinogram(values, angles, np.linspace(0, 0.25, N_VIEWS), **GEOMETRY.keys())


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
