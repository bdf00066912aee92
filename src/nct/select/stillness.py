"""The ladder a scan's views leave to fit: where their conjugate views agree to their noise
(moments/conjugates.py), nothing moves and a ladder holding the static rung fits it alone; where they differ beyond
it, something moves and the static rung is not fitted. The rungs left out are listed in selection.csv with why."""

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
    """``motion``'s ladder for ``sino``, where it holds the static rung and moving ones, read off the views'
    conjugate ratio: at most ``motion.still_ratio``, the static rung alone (nothing moves); above, the moving rungs
    alone (something does). All of it where the views cannot tell (half a turn or less) or the rule is off."""
    if "static" not in motion.rungs or len(motion.rungs) == 1 or motion.still_ratio <= 0:
        return Ladder(motion)
    ratio = conjugate_ratio(sino)
    if math.isnan(ratio):  # under half a turn: no conjugate pairs
        return Ladder(motion)
    still = ratio <= motion.still_ratio
    kept = ["static"] if still else [r for r in motion.rungs if r != "static"]
    left_out = [r for r in motion.rungs if r not in kept]
    why = (f"the views' conjugate pairs agree to their noise (ratio {ratio:.3g} <= motion.still_ratio "
           f"{motion.still_ratio:g}): nothing moves" if still else
           f"the views' conjugate pairs differ beyond their noise (ratio {ratio:.3g} > motion.still_ratio "
           f"{motion.still_ratio:g}): something moves")
    log.info("motion: %s; %s not fitted (motion.still_ratio=0 fits every rung)", why, ", ".join(left_out))
    return Ladder(replace(motion, rungs=kept), left_out, why)
