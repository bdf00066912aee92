"""The stages' loss terms: the balanced L1 of InitFit weighs an object's inside as much as its outside."""

from __future__ import annotations

import pytest
import torch

from nct.fit.stages import balanced_l1


def test_balanced_l1_weighs_inside_and_outside_equally():
    """One inside pixel counts as much as the 15 outside: a field negative everywhere is no fit."""
    targets = -torch.ones(1, 1, 4, 4)
    targets[0, 0, 1, 1] = 1.0
    everywhere_outside = -torch.ones(1, 1, 4, 4)
    assert float(balanced_l1(everywhere_outside, targets)) == pytest.approx(0.5 * (2.0 + 0.0))
    assert float((everywhere_outside - targets).abs().mean()) == pytest.approx(2 / 16)  # what plain L1 gave
