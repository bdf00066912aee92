"""simulate: exact data when noiseless, Poisson noise of the documented size, truth attached."""

import numpy as np
import pytest

from nct.scenes.phantoms import CircleConf, StaticConf, build_phantom
from nct.acquisition.scanner import ImageGrid, Scanner
from nct.scenes.simulate import attenuation_scale, simulate

GRID = ImageGrid(32, extent=1.0)
SCANNER = Scanner(views_per_rotation=60, rotations=1.0, rotation_time=0.25, n_bins=48, bin_spacing=1 / 32)
TIMES = SCANNER.frame_times(4)


def run(noise_i0, seed=0, conf=None):
    phantom = build_phantom(conf or CircleConf(), SCANNER.rotation_time)
    return simulate(phantom, SCANNER, GRID, TIMES, noise_i0, np.random.default_rng(seed))


def test_noiseless_is_the_phantom_projection_with_scanner_geometry():
    sino = run(None)
    phantom = build_phantom(CircleConf(), SCANNER.rotation_time)
    assert np.array_equal(sino.values, phantom.project(SCANNER, GRID))
    assert sino.values.dtype == np.float32 and sino.values.shape == (60, 48)
    assert np.array_equal(sino.angles, SCANNER.angles) and np.array_equal(sino.times, SCANNER.times)
    assert sino.bin_spacing == SCANNER.bin_spacing


def test_same_seed_same_sinogram():
    assert np.array_equal(run(1e4, seed=3).values, run(1e4, seed=3).values)
    assert not np.array_equal(run(1e4, seed=3).values, run(1e4, seed=4).values)


def test_noise_matches_poisson_prediction_and_falls_with_i0():
    clean = run(None).values
    background = clean == 0  # rays that miss the object: p_noisy = -log(N / I0) / k
    k = attenuation_scale(GRID.extent)
    stds = []
    for i0 in (1e3, 1e5):
        noise = run(i0).values - clean
        stds.append(noise[background].std())
        assert stds[-1] == pytest.approx(1 / (k * np.sqrt(i0)), rel=0.1)
        assert abs(noise.mean()) < 3 * stds[-1] / np.sqrt(noise.size) + 1 / i0  # unbiased to O(1/I0)
    assert stds[0] / stds[1] == pytest.approx(10, rel=0.15)


def test_truth_frames_times_and_level():
    sino = run(None, conf=StaticConf(large_intensity=1.0, small_intensity=0.4))
    truth = sino.truth
    assert truth.frames.shape == (4, 32, 32) and truth.frames.dtype == np.float32
    assert np.array_equal(truth.times, TIMES) and truth.extent == GRID.extent
    assert truth.level == pytest.approx(0.2)
    assert truth.frames.max() == pytest.approx(1.0)


@pytest.mark.parametrize("i0", [0.0, -5.0, float("inf")])
def test_bad_noise_i0_raises(i0):
    with pytest.raises(ValueError, match="noise_i0"):
        run(i0)


def test_bad_frame_times_raise():
    phantom = build_phantom(CircleConf(), SCANNER.rotation_time)
    with pytest.raises(ValueError, match="frame_times"):
        simulate(phantom, SCANNER, GRID, np.array([]), None, np.random.default_rng(0))
