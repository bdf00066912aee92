"""The method's own units: the same scene in any length and intensity units gives the same result."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from nct.acquisition.scanner import ImageGrid
from nct.acquisition.sinogram import Sinogram
from nct.errors import NoObjectError
from nct.fit.conf import LossConf
from nct.fit.units import Units
from nct.method.reconstruct import reconstruct
from nct.run.metrics import frame_metrics
from tests.conftest import INIT, MODEL, NO_BACKGROUND, TRAINER, moving_disc
from tests.conftest import OPTIM as SHORT

# The default schedule's shape, shortened: ten decays over the fit, so it ends at about 2 % of its rate
# as a default run does. Decaying every 30 of 60 steps ended at 42 %, in a noisy phase where a
# rounding difference of 1e-7 (the units' rescaling) moved the held-out loss from 0.025 to 0.043
# and the Dice by 0.016 (a fresh environment, one thread).
OPTIM = replace(SHORT, init_steps=40, fit_steps=60, lr_decay_every=6)


@pytest.fixture(scope="module")
def scene():
    """A disc at 60 deg/rotation on a 32-pixel unit field of view, its sinogram and frame times."""
    return moving_disc()


def rescaled(sino: Sinogram, length: float, intensity: float) -> Sinogram:
    """The same acquisition written with lengths x ``length`` and intensities x ``intensity``."""
    values = (sino.values.astype(np.float64) * length * intensity).astype(np.float32)
    return Sinogram(values, sino.angles, sino.times, sino.geometry.scaled(length))


def dice_in(sino: Sinogram, times: np.ndarray, length: float, intensity: float) -> tuple[float, np.ndarray]:
    """Median NCT Dice of the scene written in the given units, and its frames in unit terms."""
    grid = ImageGrid(32, length)
    result = reconstruct(rescaled(sino, length, intensity), grid, times, MODEL, LossConf(), TRAINER, 0,
                         log_dir=None, logger="none", optim=OPTIM, init=INIT, background=NO_BACKGROUND)
    truth = sino.truth
    scores = frame_metrics(result.frames, truth.frames * intensity, truth.level * intensity)
    assert result.init["length_unit"] == pytest.approx(length)
    return float(np.median(scores.dice)), result.frames / intensity


@pytest.fixture(scope="module")
def own_units(scene) -> tuple[float, np.ndarray]:
    """The scene's fit in its own units (`dice_in` at 1, 1), which every rescaled fit is compared with."""
    sino, times = scene
    return dice_in(sino, times, 1.0, 1.0)


@pytest.mark.parametrize("length, intensity", [(25.0, 1.0), (250.0, 1e-3), (1.0, 1e3), (250.0, 1e3), (0.01, 1e-3)])
def test_same_dice_in_any_units(scene, own_units, length, intensity):
    sino, times = scene
    reference, frames = own_units
    assert reference > 0.8  # the check below compares real reconstructions, not two failures
    scaled, scaled_frames = dice_in(sino, times, length, intensity)
    assert scaled == pytest.approx(reference, abs=0.01)
    assert np.abs(scaled_frames - frames).mean() < 0.01  # boundaries within a fraction of a pixel


def test_units_map_and_refuse_an_empty_sinogram():
    units = Units(length=200.0).with_intensity_of(np.full((2, 4, 4), 0.02) + np.eye(4) * 0.5)
    assert units.intensity == pytest.approx(0.52)
    assert units.grid(ImageGrid(8, 200.0)).extent == pytest.approx(1.0)
    with pytest.raises(NoObjectError, match="no positive intensity"):
        Units(length=1.0).with_intensity_of(np.zeros((2, 4, 4)))
    with pytest.raises(ValueError, match="length"):
        Units(length=0.0)
