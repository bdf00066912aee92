"""The truth-free suspect-fit rule: the noise's misfit read off the data, FBP's held-out misfit,
and the warnings from the fit's misfit against both."""

import math
from dataclasses import replace

import numpy as np
import pytest

from nct.acquisition.scanner import ImageGrid, Scanner
from nct.fit.conf import HeldoutConf
from nct.physics.conf import FBPConf
from nct.run.conf import SuspectConf
from nct.run.suspect import (
    HeldoutMisfits,
    heldout_misfits,
    noise_misfit,
    suspect_warnings,
)
from nct.scenes.phantoms import CircleConf, build_phantom
from nct.scenes.simulate import simulate

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


@pytest.mark.parametrize(("misfits", "reasons"), [
    (HeldoutMisfits(nct=0.07, fbp=0.11, noise=0.0), []),  # like the letters experiment
    (HeldoutMisfits(nct=0.09, fbp=0.03, noise=0.0), ["FBP's"]),  # one object fitted for two
    (HeldoutMisfits(nct=0.14, fbp=0.29, noise=0.0), ["unexplained"]),  # a fan scan read as parallel
    (HeldoutMisfits(nct=0.20, fbp=0.09, noise=0.0), ["FBP's", "unexplained"]),  # far too few steps
    (HeldoutMisfits(nct=0.27, fbp=0.28, noise=0.23), []),  # noisy data: only what is beyond the noise counts
])
def test_warnings_say_why(misfits: HeldoutMisfits, reasons: list[str]):
    lines = suspect_warnings(misfits, SuspectConf(), from_file=True)
    assert len(lines) == len(reasons)
    assert all(line.startswith("suspect fit") and reason in line for line, reason in zip(lines, reasons))


def test_a_simulation_is_never_told_its_file_is_wrong():
    """A simulated scan's geometry is the one that made its data: its warnings blame no file."""
    misfits = HeldoutMisfits(nct=0.20, fbp=0.09, noise=0.0)
    filed, simulated = (suspect_warnings(misfits, SuspectConf(), from_file=f) for f in (True, False))
    assert len(simulated) == len(filed) == 2 and "file" in filed[1]
    assert not any("file" in line or "geometry" in line for line in simulated)


def test_thresholds_come_from_the_config():
    misfits = HeldoutMisfits(nct=0.07, fbp=0.11, noise=0.0)
    assert suspect_warnings(misfits, SuspectConf(fbp_ratio=0.5), True)
    assert suspect_warnings(misfits, SuspectConf(excess=0.05), True)
    with pytest.raises(ValueError, match="suspect.excess"):
        SuspectConf(excess=0.0)
