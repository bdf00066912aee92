"""The run's truth-free verdict on motion along the rays (nct.moments.determinacy), on tiny simulated scans."""

import json

import numpy as np
import pytest

from nct.analysis.benchmarking import QUIET
from nct.moments.determinacy import (
    determinacy_warnings,
    motion_determinacy,
    turn_coverage,
    turn_warnings,
)
from nct.run.config import validate
from nct.run.job import run_job
from nct.run.pipeline import acquire

# The circle at 300 deg/rotation as the trajectory benchmark scans it (128 px, 720 views): 7.6 px, a poor fit
FAST = ("phantom.displacement_deg=300", "image.size=128", "scanner.n_bins=128", "scanner.views_per_rotation=720")


def verdict(tiny_cfg, *overrides):
    scan = acquire(validate(tiny_cfg(*overrides)), np.random.default_rng(0))
    return motion_determinacy(scan.sinogram, scan.grid)


@pytest.mark.parametrize("overrides, determined", [
    (FAST, False),  # a fast orbit: the ray's direction turns with it
    (("phantom.displacement_deg=360",), True),  # the same at 32 px and 60 views: 1.1 px, within the limit
    (("phantom.displacement_deg=30",), True),
    (("experiment=static",), True),  # two objects, no motion: their joint centroid is still
])
def test_verdict_follows_the_speed(tiny_cfg, overrides, determined):
    m = verdict(tiny_cfg, *overrides)
    assert m.determined is determined, m
    assert (determinacy_warnings(m) == []) is determined
    if not determined:
        assert "more rotations or a motion prior needed" in determinacy_warnings(m)[0]


def test_views_that_give_no_trajectory_give_no_verdict(tiny_cfg):
    scan = acquire(validate(tiny_cfg()), np.random.default_rng(0))
    sino = scan.sinogram
    empty = type(sino)(values=np.zeros_like(sino.values), angles=sino.angles, times=sino.times, geometry=sino.geometry)
    assert motion_determinacy(empty, scan.grid) is None and determinacy_warnings(None) == []


def test_run_records_the_verdict(tiny_cfg, run_dir):
    run_job(tiny_cfg("method=fbp", *FAST, *QUIET), run_dir)
    motion = json.loads((run_dir / "metrics.json").read_text())["motion_determinacy"]
    assert set(motion) >= {"ray_spread_px", "threshold_px", "determined", "length_scale_rot", "misfit_px"}
    assert motion["determined"] is False and motion["ray_spread_px"] > motion["threshold_px"]
    warnings = json.loads((run_dir / "status.json").read_text())["warnings"]
    assert any(w.startswith("motion along the rays is not determined") for w in warnings)


@pytest.mark.parametrize("rate, coverage, model, warned", [
    (100.0, 260.0, ("method=fbp",), False),
    (250.0, 110.0, ("method=fbp",), False),  # under half a turn, above the limit the prior fills (TURN_WARN_DEG)
    (300.0, 60.0, ("data.n_objects=2",), True),  # read off the data whatever the model: two objects fitted
])
def test_a_bar_turning_with_the_gantry_is_warned(tiny_cfg, run_dir, rate, coverage, model, warned):
    """The bar turning 300 deg/rotation over one rotation is seen in its own frame over 60 deg of view
    angle alone (metrics.json; the 60 views span 59/60 of the rotation): warned, also where the run fits
    two objects; over 260 or 110 deg: not."""
    run_job(tiny_cfg("experiment=bar", f"phantom.objects.0.angle_deg.rate={rate}", *model, *QUIET), run_dir)
    assert json.loads((run_dir / "metrics.json").read_text())["turn_coverage_deg"] == pytest.approx(
        coverage * 59 / 60, abs=1.0)
    warnings = json.loads((run_dir / "status.json").read_text())["warnings"]
    assert any("turns with the gantry" in w for w in warnings) is warned
    assert turn_warnings(None) == []


def test_no_turn_is_read_where_no_axis_is_held(tiny_cfg):
    """A disc has no axis, and an orbiting one no still centre: no coverage, no warning."""
    scan = acquire(validate(tiny_cfg()), np.random.default_rng(0))
    assert turn_coverage(scan.sinogram) is None
