"""benchmarks/trajectory.py: its ambiguity figure shows two trajectories with one sinogram, and its
table rows score the fit against the truth."""

from __future__ import annotations

import matplotlib.pyplot as plt

from tests.conftest import figure_problems
from tests.conftest import load_benchmark as load_script

trajectory = load_script("trajectory")


def test_two_trajectories_give_one_sinogram():
    """The shifted disc moves up to 0.12 of the field along the rays; its closed-form sinogram is the
    circle's to rounding (measured 7e-12); the figure explains itself in units of the field of view."""
    fig, difference = trajectory.ambiguity_figure()
    assert difference < 1e-9
    assert figure_problems(fig, ("field of view",)) == []
    plt.close(fig)


def test_a_row_scores_the_fit_against_the_truth():
    row = trajectory.measure(100.0, 1.0, None)
    assert row["centroid_error_px"] < 0.01 and row["error_max_px"] < 0.3 and row["determined"]
    assert row["error_rms_px"] <= row["error_max_px"] and row["legendre_error_max_px"] > row["error_max_px"]
