"""moments/conjugates.py: a still disc's conjugate views agree to the interpolation's error, an orbiting one's do
not, and a scan of under half a turn has no conjugates."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from nct.moments.conjugates import conjugate_mismatch, conjugate_ratio
from tests.conftest import circle


@pytest.mark.parametrize("deg, low, high", [(0.0, 0.0, 1e-6), (5.0, 5.0, 10.0), (100.0, 100.0, 200.0)])
def test_conjugates_tell_a_still_disc_from_a_moving_one(deg, low, high):
    """Noiseless, 180 views of 48 bins: a still disc reads ~4e-8, one orbiting at 5 deg a rotation 7.5, at 100 deg
    145: motion far above the limit of 1 (motion.still_ratio)."""
    sino, _, _ = circle(deg, views=180, size=48)
    assert low <= conjugate_ratio(sino) <= high, (deg, conjugate_mismatch(sino))


def test_under_half_a_turn_there_are_no_conjugates():
    sino, _, _ = circle(0.0, views=180, size=48)
    short = replace(sino, values=sino.values[:80], angles=sino.angles[:80], times=sino.times[:80])
    assert all(math.isnan(x) for x in conjugate_mismatch(short)) and math.isnan(conjugate_ratio(short))
    assert np.isfinite(conjugate_mismatch(sino)).all()


def test_angles_wrapped_at_a_turn_read_as_the_turning_gantry():
    sino, _, _ = circle(100.0, rotations=1.5, views=120, size=48)
    wrapped = replace(sino, angles=np.mod(np.asarray(sino.angles), 2 * np.pi))
    assert conjugate_mismatch(wrapped) == pytest.approx(conjugate_mismatch(sino))
