"""The tournament's settings (config group ``motion``): a plain dataclass without torch, so that parsing a
config (``nct.run.config.validate``) stays cheap."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Optional

from nct.errors import require
from nct.fields.conf import RUNGS


@dataclass
class SelectionConf:
    """The tournament's settings (config group ``motion``: its options static_or_free, the default,
    auto, static, rigid, affine, free).

    rungs: the motion models tried (RUNGS), or one of them (no tournament between rungs then).
    first_budget: share of a fit's steps at the schedule's first milestone (then twice, four times ...).
    tolerance: relative held-out misfit within which a simpler model beats a better one. Interleaved
        held-out views flatter a freer model (it explains them better with wrong shapes): a wider
        temporal band lowered the held-out loss on 23 of 27 scenes, and gained Dice only where it
        brought it to 0.6x or below (benchmarks/results/generalisation/band), hence 2/3.
    band_f_max: on scans of at least ``band_min_rotations`` rotations the free rung is also tried
        with frequencies of this spread (model.f_max; cycles per rotation): ellipses turning near
        180 deg/rotation change at about one cycle per rotation (null: never).
    milestone_margin: a fit stops at a milestone only above (1 + this) x what it needs to win there: two
        starts of the thorax met within 1-3.5 % at step 300 or 500 and the one behind finished ahead on
        2 of seeds 0-4 (seed 0's heart 0.975 -> 0.981, for 1.35x the run's time); the fixed subset's stopped
        fits were 12 % or more behind and none would have won (benchmarks/results/background, session 45).
    scene_tolerance: relative held-out misfit within which a simpler scene model (fewer objects; no background
        before a static image) beats a better one, compared at the same rung (select/tournament.py).
    scene_budget: share of a fit's steps before which milestones compare no two scene models: a model with more
        objects starts further from its end (the nodule's three objects 79 % behind two at step 300, 0.67x
        their held-out misfit at the end); from half the steps, 4 of 18 generalisation scenes whose truth's model was
        stopped at step 300 chose it, each at a better Dice and MSE, for 1.29x their time
        (benchmarks/results/generalisation/scene_budget).
    fbp_ratio: a winner whose held-out misfit beyond the noise's is above this x FBP's races the next scene model by
        price too (select/race.py): a first winner worse than FBP on the views its fit never saw was a scene model the
        judge priced wrong on four of the 100 generalisation scenes (benchmarks/results/generalisation/reserve). A
        race costs time, never the result (the held-out views still choose), so it starts below the limit at which
        the run warns (suspect.fbp_ratio); 0: every winner races the next model, .inf: none does.
    still_ratio: a ladder of the static rung and moving ones fits static alone where the views' conjugate ratio
        (moments/conjugates.py: conjugate views against their noise) is at most this, the moving rungs alone above it
        (select/stillness.py): of the benchmarks' 118 scene files no moving one reads under 1.03, 26 of 28 still ones
        under 1.0 (benchmarks/results/speed/conjugate_views); the still experiment with motion=auto then takes a
        quarter of its time, and the default ladder (static, free) fits a moving scan as motion=free does. 0: never.
    """

    rungs: list[str] = field(default_factory=lambda: ["free"])
    first_budget: float = 0.25
    tolerance: float = 2 / 3
    band_f_max: Optional[float] = 0.5
    band_min_rotations: float = 1.5
    milestone_margin: float = 0.05
    scene_tolerance: float = 0.1
    scene_budget: float = 0.5
    fbp_ratio: float = 1.0
    still_ratio: float = 1.0

    def __post_init__(self) -> None:
        require(len(self.rungs) >= 1 and all(r in RUNGS for r in self.rungs), "motion.rungs",
                f"a non-empty list of {', '.join(RUNGS)}", self.rungs)
        require(len(set(self.rungs)) == len(self.rungs), "motion.rungs", "without repeats", self.rungs)
        require(0 < self.first_budget <= 1, "motion.first_budget", "in (0, 1]", self.first_budget)
        require(self.tolerance >= 0, "motion.tolerance", ">= 0", self.tolerance)
        require(self.scene_tolerance >= 0, "motion.scene_tolerance", ">= 0", self.scene_tolerance)
        require(0 <= self.scene_budget <= 1, "motion.scene_budget", "in [0, 1]", self.scene_budget)
        require(self.still_ratio >= 0, "motion.still_ratio", ">= 0", self.still_ratio)
        require(self.fbp_ratio >= 0, "motion.fbp_ratio", ">= 0", self.fbp_ratio)
        require(self.milestone_margin >= 0, "motion.milestone_margin", ">= 0", self.milestone_margin)
        require(self.band_f_max is None or self.band_f_max > 0, "motion.band_f_max", "> 0 or null", self.band_f_max)
