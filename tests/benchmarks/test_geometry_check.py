"""benchmarks/geometry_check.py: its rewritten files carry the intended wrong geometry, and its table
row says which check warns."""

from __future__ import annotations

import numpy as np
import pytest

from nct.acquisition.geometry import ParallelGeometry
from nct.acquisition.io import load_sinogram, save_sinogram
from nct.acquisition.scanner import ImageGrid, Scanner
from nct.scenes.phantoms import ComposedConf, build_phantom
from nct.scenes.simulate import simulate
from tests.conftest import load_benchmark, still

bench = load_benchmark("geometry_check")


@pytest.fixture
def fan_file(tmp_path):
    """A still off-centre ellipse in fan beam, 90 views of 48 bins, as a file."""
    scanner = Scanner(views_per_rotation=90, n_bins=48, bin_spacing=2.1 / 48, source_distance=2.0,
                      detector_distance=2.0, detector_shape="flat")
    phantom = build_phantom(ComposedConf(objects=[still(0.12, -0.06, 0.2, 0.12, 1.0)]), scanner.rotation_time)
    sino = simulate(phantom, scanner, ImageGrid(32), scanner.frame_times(3), None, np.random.default_rng(0))
    save_sinogram(tmp_path / "fan.npz", sino)
    return tmp_path / "fan.npz"


def test_rewritten_files_carry_the_wrong_geometry(fan_file, tmp_path):
    right = load_sinogram(fan_file).geometry
    shifted = load_sinogram(bench.rewrite(fan_file, tmp_path / "a.npz", offset_bins=3, spacing=1.05)).geometry
    assert shifted.detector_offset == pytest.approx(right.detector_offset + 3 * right.bin_spacing)
    assert shifted.bin_spacing == pytest.approx(1.05 * right.bin_spacing)
    parallel = load_sinogram(bench.rewrite(fan_file, tmp_path / "b.npz", as_parallel=True)).geometry
    assert parallel == ParallelGeometry(right.n_bins, right.bin_spacing, right.detector_offset)


def test_rows_say_which_check_warns(fan_file, tmp_path):
    assert bench.row("ok", fan_file).endswith("| - |")
    assert bench.row("off", bench.rewrite(fan_file, tmp_path / "a.npz", offset_bins=3)).endswith("| offset |")
    as_parallel = bench.row("par", bench.rewrite(fan_file, tmp_path / "b.npz", as_parallel=True))
    assert as_parallel.endswith("| fan read as parallel |") and as_parallel.count("|") == 7
