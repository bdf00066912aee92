"""benchmarks/diagnostics/conjugate_views.py: a still disc's conjugate views agree to the interpolation's error,
an orbiting one's do not, and a scan of under half a turn has no conjugates."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from tests.conftest import circle, load_benchmark

conjugate_views = load_benchmark("diagnostics/conjugate_views")


@pytest.mark.parametrize("deg", [0.0, 100.0])
def test_conjugates_tell_a_still_disc_from_a_moving_one(deg):
    sino, _, _ = circle(deg, views=180, size=48)
    conjugate, neighbour = conjugate_views.consistency(sino)
    ratio = conjugate / neighbour
    assert (ratio < 1.0) if deg == 0 else (ratio > 10.0), (deg, conjugate, neighbour)


def test_under_half_a_turn_there_are_no_conjugates():
    sino, _, _ = circle(0.0, views=180, size=48)
    short = replace(sino, values=sino.values[:80], angles=sino.angles[:80], times=sino.times[:80])
    assert all(math.isnan(x) for x in conjugate_views.consistency(short))
    assert np.isfinite(conjugate_views.consistency(sino)).all()


def test_angles_wrapped_at_a_turn_read_as_the_turning_gantry():
    sino, _, _ = circle(100.0, rotations=1.5, views=120, size=48)
    wrapped = replace(sino, angles=np.mod(np.asarray(sino.angles), 2 * np.pi))
    assert conjugate_views.consistency(wrapped) == pytest.approx(conjugate_views.consistency(sino))
