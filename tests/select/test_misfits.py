"""The held-out misfits' references from the data alone: the noise's read off the data, FBP's from the fitted
views; and the rule a fit worse than FBP fails."""

import math
from dataclasses import replace

import numpy as np
import pytest

from nct.acquisition.scanner import ImageGrid, Scanner
from nct.fit.conf import HeldoutConf
from nct.physics.conf import FBPConf
from nct.scenes.phantoms import CircleConf, build_phantom
from nct.scenes.simulate import simulate
from nct.select.misfits import HeldoutMisfits, heldout_misfits, noise_misfit

GRID = ImageGrid(64)


def disc_scan(displacement_deg: float, views: int = 360):
    """A disc orbiting ``displacement_deg`` per rotation, ``views`` views of 64 bins, noiseless."""
    scanner = Scanner(views_per_rotation=views, rotations=1.0, rotation_time=0.25, n_bins=64, bin_spacing=1 / 64)
    phantom = build_phantom(CircleConf(radius=0.15, orbit_radius=0.2, displacement_deg=displacement_deg),
                            scanner.rotation_time)
    return simulate(phantom, scanner, GRID, scanner.frame_times(4), None, np.random.default_rng(0))


def test_noise_misfit_reads_the_noise_off_the_data():
    sino = disc_scan(100.0)
    assert noise_misfit(sino.values) < 0.003  # noiseless: the edges moving past do not count as noise
    scale = float(np.abs(sino.values).mean())
    noisy = sino.values + np.random.default_rng(1).normal(0.0, 0.05 * scale, sino.values.shape)
    assert noise_misfit(noisy) == pytest.approx(math.sqrt(2 / math.pi) * 0.05, rel=0.1)  # E|noise| / scale


def test_fbp_misfit_grows_with_motion_and_skips_runs_without_held_out_views():
    still, moving = (heldout_misfits(disc_scan(d), GRID, 0.01, HeldoutConf(), FBPConf()) for d in (0.0, 150.0))
    assert still.fbp < 0.05 and moving.fbp > 2 * still.fbp  # FBP's motion blur shows on the held-out views
    assert still.nct == 0.01 and still.noise < 0.003
    assert heldout_misfits(disc_scan(0.0), GRID, 0.01, replace(HeldoutConf(), every=0), FBPConf()) is None
    assert heldout_misfits(disc_scan(0.0), GRID, math.nan, HeldoutConf(), FBPConf()) is None


def test_worse_than_fbp_counts_only_what_is_beyond_the_noise():
    assert HeldoutMisfits(nct=0.09, fbp=0.03, noise=0.0).above_fbp(1.0)  # one object fitted for two
    assert not HeldoutMisfits(nct=0.07, fbp=0.11, noise=0.0).above_fbp(1.0)  # like the letters experiment
    assert not HeldoutMisfits(nct=0.27, fbp=0.28, noise=0.23).above_fbp(1.0)  # noisy: 0.04 beyond against 0.05
    assert HeldoutMisfits(nct=0.27, fbp=0.28, noise=0.23).above_fbp(0.5)  # the ratio is the caller's
