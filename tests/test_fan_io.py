"""The sinogram file's geometry keys: fan beam, detector shape and offset round-trip; bad values name the key."""

from __future__ import annotations

import json

import numpy as np
import pytest
from geometry_cases import GEOMETRIES, closed_form_sinogram

from nct.errors import InputError
from nct.acquisition.geometry import ParallelGeometry
from nct.acquisition.io import load_sinogram, save_sinogram
from nct.scenes.phantoms import StaticConf, build_phantom
from nct.run.pipeline import run_job
from nct.acquisition.scanner import ImageGrid, Scanner
from nct.scenes.simulate import simulate
from nct.acquisition.sinogram import Sinogram


def write(path, geometry, **changes) -> None:
    """A valid file of ``geometry`` (analytic ellipses, 12 views) with keys changed (None: removed)."""
    angles = np.linspace(0, 2 * np.pi, 12, endpoint=False)
    values = closed_form_sinogram(geometry, angles).astype(np.float32)
    save_sinogram(path, Sinogram(values, angles, np.linspace(0, 0.25, 12), **geometry.keys()))
    with np.load(path) as data:
        arrays = dict(data)
    arrays.update({k: v for k, v in changes.items() if v is not None})
    for key in [k for k, v in changes.items() if v is None]:
        del arrays[key]
    np.savez(path, **arrays)


@pytest.mark.parametrize("geometry", GEOMETRIES.values(), ids=GEOMETRIES.keys())
def test_geometry_round_trips(tmp_path, geometry):
    write(tmp_path / "s.npz", geometry)
    sino = load_sinogram(tmp_path / "s.npz")
    assert sino.geometry == geometry


def test_a_file_without_geometry_keys_is_centred_parallel_beam(tmp_path):
    write(tmp_path / "s.npz", GEOMETRIES["parallel"], detector_offset=None)
    assert load_sinogram(tmp_path / "s.npz").geometry == ParallelGeometry(96, 1 / 64)


def test_flat_is_the_default_detector_shape(tmp_path):
    write(tmp_path / "s.npz", GEOMETRIES["fan-curved"], detector_shape=None)
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
    write(tmp_path / "s.npz", GEOMETRIES[geometry], **changes)
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
                     "logger=none", "export.gif=false", "export.tiff=false"), run_dir)
    assert json.loads((run_dir / "metrics.json").read_text())["fbp"]["median_dice"] >= 0.98
    assert load_sinogram(run_dir / "sinogram.npz").geometry == geometry
