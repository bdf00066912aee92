"""How well a run's data determine the motion along the rays, from the sinogram alone (issue 27, item 4).

`nct.moments.trajectory` fits the moving mass's centroid trajectory to each view's first moment and
measures the spread, along the ray of the view taken at each instant, between equally good fits:
motion along that ray changes no view, so only a prior over time fills it in. With several objects
the first moment is the whole mass's centroid: the verdict is on where the total mass goes, and an
object moving against another (their centroid still) can go unflagged; a still scene reads 0 px.
An object turned with a held axis (a lone one's or one part's among still ones: moments/orientation.py)
is seen in its own frame over the span of θ − φ(t) alone: below half a turn, what those views leave
open of its shape is the prior's. Both are read off the whole sinogram, whatever model the run fits.
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass

from nct.acquisition.scanner import ImageGrid
from nct.acquisition.sinogram import Sinogram
from nct.moments.orientation import frame_coverage, orientation_path, turning_part
from nct.moments.trajectory import centroid_projections, determinacy, fit_trajectory

log = logging.getLogger(__name__)
HALF_TURN_DEG = 180.0  # parallel views over half a turn determine a still shape
# The turn warning speaks under this coverage (degrees), not under HALF_TURN_DEG: with the prior's help fits stay
# good down to 90 deg (the bar: Dice 0.997 at 160, 135 and 110 deg, 0.878 at 90 against FBP's 0) and go poor
# from 70 deg (the bar: 0.06, 0, 0 at 70, 45, 20 deg); a fatter ellipse is poor at 110 and 20 deg, at FBP's
# level between (benchmarks/results/warnings/turn_limit/). At 180 it warned 9 good fits of 14 there and
# generalisation's scene032 (159 deg, Dice 0.948 against FBP's 0.931); at 80 none of its 100 scenes warns.
TURN_WARN_DEG = 80.0


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


def turn_coverage(sino: Sinogram) -> float | None:
    """Degrees of view angle over which a turning object's own frame is seen in ``sino``, read off the whole
    views' second moments (orientation.py): a lone rigid shape's held axis, else one turning part's among still
    ones; None where neither is held (a disc, a shape that changes, several movers, fan beam)."""
    axis = orientation_path(sino)
    if axis is None or not axis.held:
        axis = turning_part(sino)
    return None if axis is None or not axis.held else frame_coverage(sino, axis)


def turn_warnings(coverage: float | None) -> list[str]:
    """status.json's warning line when a turning object's own frame is seen over less than TURN_WARN_DEG of view
    angle (``coverage``, `turn_coverage`), else none."""
    if coverage is None or coverage >= TURN_WARN_DEG:
        return []
    return [f"the moving object turns with the gantry: its own frame is seen over {coverage:.0f} deg of view angle, "
            f"less than the {HALF_TURN_DEG:.0f} deg that determine a shape; the rest of its shape is the prior's "
            "guess: more rotations or a slower turn needed"]
