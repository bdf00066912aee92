"""A moving object in static surroundings (issue 9, item 5), on tiny sizes: a vessel orbiting inside
a dimmer static body, and a bright disc orbiting beside a dimmer static disc (K = 2). The moving
object is scored at its own level (its container's level plus half its own), the static scene's
foreground against FBP's."""

from __future__ import annotations

import numpy as np
import pytest

from nct.acquisition.scanner import ImageGrid
from nct.physics.fbp import fbp_frames
from nct.run.metrics import dice
from tests.conftest import LONGER, fit_composed, orbit, still

GRID = ImageGrid(40)
SCENES = {  # objects, the moving object's own level
    "vessel": ([still(0.0, 0.0, 0.32, 0.26, 0.4), orbit(0.1, 0.12, 100.0, 1.0)], 0.4 + 0.5),
    "beside": ([orbit(0.12, 0.2, 100.0, 1.0), still(-0.22, -0.2, 0.12, 0.12, 0.45)], 0.5),
}
# Measured (median over frames, 200-step fit; FBP levels, init.levels=fbp): at its own level NCT 0.922 / FBP 0.842
# (vessel), 0.901 / 0.786 (beside); the foreground 0.988 / 0.981 and 0.938 / 0.818 (before the coarse first pass:
# 0.913 and 0.892 at the own level). The bars sit 0.03-0.04 below NCT's own-level scores. With the judged levels (the
# default) the own level reads 0.915 (vessel) and 0.884 (beside), the foreground 0.989 and 0.930.
# (A vessel of radius 0.05 at 64-128 px stays below 0.85: benchmarks/results/surround.)
OWN_LEVEL = {"vessel": 0.88, "beside": 0.86}
# One fit's score at this size moves with the order of its sums: the vessel's at its own level, seeds 0-3, read
# 0.887, 0.946, 0.906, 0.923 with one thread on an Intel Xeon and 0.899, 0.947, 0.906, 0.922 with two (seed 0 had
# read 0.915 on an AMD EPYC); beside's 0.881-0.900. So each score is the median of three seeds' fits.
SEEDS = (0, 1, 2)


@pytest.mark.parametrize("name", SCENES)
def test_moving_object_in_static_surroundings(name):
    objects, own = SCENES[name]
    fits = [fit_composed(objects, GRID, LONGER, seed=seed) for seed in SEEDS]
    sino, times = fits[0][:2]
    fbp = fbp_frames(sino, GRID, times)
    truth = sino.truth.frames

    def score(frames: np.ndarray, level: float) -> float:
        return float(np.median(dice(frames >= level, truth >= level)))

    def nct(level: float) -> float:
        return float(np.median([score(result.frames, level) for *_, result in fits]))

    own_nct = nct(own)
    assert own_nct > OWN_LEVEL[name], own_nct
    assert own_nct > score(fbp, own) + 0.05, (own_nct, score(fbp, own))
    assert nct(sino.truth.level) >= score(fbp, sino.truth.level) - 0.01
