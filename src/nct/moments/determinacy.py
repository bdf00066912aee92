"""How well a run's data determine the motion along the rays, from the sinogram alone (issue 27, item 4).

`nct.moments.trajectory` fits the moving mass's centroid trajectory to each view's first moment and
measures the spread, along the ray of the view taken at each instant, between equally good fits:
motion along that ray changes no view, so only a prior over time fills it in. With several objects
the first moment is the whole mass's centroid: the verdict is on where the total mass goes, and an
object moving against another (their centroid still) can go unflagged; a still scene reads 0 px.
An object turned with a held axis (a lone one's or one part's among still ones: moments/orientation.py)
is seen in its own frame over the span of θ − φ(t) alone: below half a turn, what those views leave
open of its shape is the prior's.
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass

from nct.acquisition.scanner import ImageGrid
from nct.acquisition.sinogram import Sinogram
from nct.moments.trajectory import centroid_projections, determinacy, fit_trajectory

log = logging.getLogger(__name__)
HALF_TURN_DEG = 180.0  # parallel views over half a turn determine a still shape


@dataclass(frozen=True)
class MotionDeterminacy:
    """metrics.json's ``motion_determinacy``: the largest spread along the rays between equally good
    centroid trajectories (pixels of the run's image grid) against ``threshold_px``, the evidence's
    prior length scale (gantry rotations), the fit's RMS misfit of the centroids (pixels) and the
    seconds the measure took."""

    ray_spread_px: float
    threshold_px: float
    determined: bool
    length_scale_rot: float
    misfit_px: float
    seconds: float


def motion_determinacy(sino: Sinogram, grid: ImageGrid) -> MotionDeterminacy | None:
    """The determinacy of the motion in ``sino`` on ``grid``'s pixels; None (logged) when the views
    give no trajectory (fewer than 3 with mass, or angles or times that do not advance)."""
    started = time.perf_counter()
    try:
        trajectory = fit_trajectory(sino.angles, sino.times, centroid_projections(sino))
    except ValueError as err:
        log.info("motion determinacy not measured: %s", err)
        return None
    verdict = determinacy(trajectory, sino.times, grid.pixel_size)
    return MotionDeterminacy(verdict.value_px, verdict.threshold_px, verdict.determined, trajectory.length_scale,
                             trajectory.residual / grid.pixel_size, time.perf_counter() - started)


def determinacy_warnings(m: MotionDeterminacy | None) -> list[str]:
    """status.json's warning line when the motion along the rays is undetermined, else none."""
    if m is None or m.determined:
        return []
    return [f"motion along the rays is not determined by these data (spread {m.ray_spread_px:.2g} px between "
            f"equally good trajectories, above {m.threshold_px:g} px): more rotations or a motion prior needed"]


def turn_warnings(init: dict) -> list[str]:
    """status.json's warning line when a held axis leaves its object's own frame seen over less than
    HALF_TURN_DEG of view angle (``init["frame_coverage_deg"]``, reconstruct's), else none."""
    coverage = init.get("frame_coverage_deg")
    if coverage is None or coverage >= HALF_TURN_DEG:
        return []
    return [f"the moving object turns with the gantry: its own frame is seen over {coverage:.0f} deg of view angle, "
            f"less than the {HALF_TURN_DEG:.0f} deg that determine a shape; the rest of its shape is the prior's "
            "guess: more rotations or a slower turn needed"]
