"""The truth-free choice among a sweep's settings: jobs grouped by scene and setting (seeds are
replicates), and the one-standard-error rule on the held-out sinogram loss.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from nct.analysis.jobs import F_MAX, TV_SPACE, TV_TIME, Job, finished, override_label
from nct.run.tables import fmt

#: The settings that order a model's freedom, and which way is simpler: a lower F_max, higher TV weights.
SIMPLER = ((F_MAX, 1.0), (TV_TIME, -1.0), (TV_SPACE, -1.0))
SCENE_KEYS = ("data", "phantom", "scanner", "image", "experiment")  # what fixes the measured scene
REPLICATE_KEY = "seed"  # a seed redraws the noise and the fit's start: a replicate of the same setting


@dataclass(frozen=True)
class Setting:
    """The finished jobs of one setting on one scene, one per seed: the truth-free score's unit.
    Over two seeds or more its held-out loss is the mean and its standard error the spread over
    seeds (a run's own error, over its held-out views, misses how much the fit itself varies)."""

    jobs: tuple[Job, ...]

    def mean(self, name: str) -> float:
        return float(np.mean([j.metric(name) for j in self.jobs]))

    @property
    def se(self) -> float:
        """The standard error of the held-out loss (0 when unknown)."""
        if len(self.jobs) > 1:
            return float(np.std([j.metric("heldout_loss") for j in self.jobs], ddof=1) / math.sqrt(len(self.jobs)))
        se = self.jobs[0].metric("heldout_se")
        return se if math.isfinite(se) else 0.0

    def get(self, key: str) -> float:
        return self.jobs[0].settings.get(key, 0.0)


def scenes(jobs: Sequence[Job]) -> dict[tuple[tuple[str, str], ...], list[Setting]]:
    """Finished jobs with a held-out loss, by scene (``SCENE_KEYS`` overrides) and setting (the other
    overrides, seed aside), so that a truth-free score may choose among settings on the same data.
    A setting counts only with every seed that any setting of its scene finished (paired replicates)."""
    by: dict[tuple[tuple[str, str], ...], dict[tuple[tuple[str, str], ...], list[Job]]] = {}
    for job in finished(jobs):
        if math.isfinite(job.metric("heldout_loss")):
            items = sorted(job.overrides.items())
            scene = tuple((k, v) for k, v in items if k.split(".")[0] in SCENE_KEYS)
            setting = tuple((k, v) for k, v in items if k.split(".")[0] not in (*SCENE_KEYS, REPLICATE_KEY))
            by.setdefault(scene, {}).setdefault(setting, []).append(job)
    out = {}
    for scene, settings in by.items():
        seeds = {j.overrides.get(REPLICATE_KEY) for group in settings.values() for j in group}
        out[scene] = [Setting(tuple(g)) for g in settings.values()
                      if {j.overrides.get(REPLICATE_KEY) for j in g} == seeds]
    return out


def truth_free_pick(settings: Sequence[Setting]) -> Setting:
    """The one-standard-error rule on settings of one scene: of the settings whose mean held-out
    loss is within one standard error (`Setting.se`, of the lowest) of the lowest, the simplest by
    the swept settings of ``SIMPLER``, then the lowest loss."""
    best = min(settings, key=lambda s: s.mean("heldout_loss"))
    bound = best.mean("heldout_loss") + best.se
    swept = [(key, sign) for key, sign in SIMPLER if len({s.get(key) for s in settings}) > 1]
    near = [s for s in settings if s.mean("heldout_loss") <= bound]
    return min(near, key=lambda s: (*(sign * s.get(key) for key, sign in swept), s.mean("heldout_loss")))


def truth_free_lines(jobs: Sequence[Job], varying: Sequence[str]) -> list[str]:
    """Per scene with two settings or more: the setting the truth-free score picks
    (``truth_free_pick``), and the Dice (mean over seeds) it gives up against the setting the truth
    would pick (the score is only comparable on the same data)."""
    lines = []
    for settings in scenes(jobs).values():
        if len(settings) < 2:
            continue
        pick = truth_free_pick(settings)
        top = max(settings, key=lambda s: s.mean("nct.median_dice"))
        lost = top.mean("nct.median_dice") - pick.mean("nct.median_dice")
        seeds = len(pick.jobs)
        lines.append(f"- {len(settings)} settings of one scene{f', {seeds} seeds each' if seeds > 1 else ''}: the "
                     f"truth-free score picks {_setting_label(pick, varying)}, NCT median Dice "
                     f"{fmt(pick.mean('nct.median_dice'))}; the best Dice is {_setting_label(top, varying)}'s "
                     f"{fmt(top.mean('nct.median_dice'))}: {fmt(lost)} lost.")
    if not lines:
        return ["Truth-free choice: none to make (no two settings ran on the same scene: the held-out loss "
                "compares settings on the same data only).", ""]
    return ["Truth-free choice (among settings of the same scene: the simplest, lowest F_max then highest TV "
            "weights, whose held-out sinogram loss is within one standard error of the lowest; over several "
            "seeds, the mean loss and Dice, and the error from the spread over seeds):", "", *lines, ""]


def _setting_label(setting: Setting, varying: Sequence[str]) -> str:
    """"job 3 (model.f_max=0.3)", or "jobs 1 5 9 (model.f_max=0.3)" for a setting over several seeds."""
    keys = [k for k in varying if k != REPLICATE_KEY]
    label = override_label(setting.jobs[0], keys) or "no varying override"
    nums = " ".join(str(j.num) for j in setting.jobs)
    return f"job{'s' if len(setting.jobs) > 1 else ''} {nums} ({label})"

