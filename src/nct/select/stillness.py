"""The ladder a scan's views leave to fit: where their conjugate views agree to their noise
(moments/conjugates.py), nothing moves, and a ladder holding the static rung fits it alone; the rungs left out
are listed in selection.csv with why."""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field, replace

from nct.acquisition.sinogram import Sinogram
from nct.moments.conjugates import conjugate_ratio
from nct.select.candidates import Candidate
from nct.select.conf import SelectionConf
from nct.select.tournament import Row

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class Ladder:
    """The ``motion`` settings whose rungs are fitted, the rungs ``left_out`` and ``why``."""

    motion: SelectionConf
    left_out: list[str] = field(default_factory=list)
    why: str = ""

    def rows(self, winner: Candidate) -> list[Row]:
        """selection.csv's line for each rung left out, as the ``winner``'s scene model would have fitted it from its
        best start (named as the winner's table names its candidates)."""
        scene = winner.scene
        return [Row(Candidate(scene, rung, scene_named=winner.scene_named).name, scene.n_objects, scene.background,
                    rung, None, 0, None, False, 0, math.nan, f"not fitted: {self.why}") for rung in self.left_out]


def ladder(sino: Sinogram, motion: SelectionConf) -> Ladder:
    """``motion``'s ladder for ``sino``: the static rung alone where it holds static and moving rungs and the views'
    conjugate ratio is at most ``motion.still_ratio``; all of it otherwise (one rung, half a turn or less, a
    ratio above)."""
    if "static" not in motion.rungs or len(motion.rungs) == 1 or motion.still_ratio <= 0:
        return Ladder(motion)
    ratio = conjugate_ratio(sino)
    if not ratio <= motion.still_ratio:  # NaN (under half a turn) too
        return Ladder(motion)
    left_out = [r for r in motion.rungs if r != "static"]
    why = (f"the views' conjugate pairs agree to their noise (ratio {ratio:.3g} <= motion.still_ratio "
           f"{motion.still_ratio:g}): nothing moves")
    log.info("motion: %s; %s not fitted (motion.still_ratio=0 fits them)", why, ", ".join(left_out))
    return Ladder(replace(motion, rungs=["static"]), left_out, why)
