"""What the benchmarks make of their records (``benchmarking.py``): Dice over seeds (a failed run
counts as 0), medians, groups by label, the Pareto front of time against score, the breakdown point
of a sweep, and a run's time extrapolated to more steps."""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import numpy as np

from nct.analysis.benchmarking import Record
from nct.run.metrics import DICE_GOOD


@dataclass(frozen=True)
class SeedStats:
    """Dice over seeds, each failed run counted as 0: n runs, n_failed, median, quartiles, range."""

    n: int
    n_failed: int
    median: float
    q25: float
    q75: float
    min: float
    max: float


def seed_stats(records: Sequence[Record]) -> SeedStats:
    """Median and spread of Dice over ``records`` (one per seed); a failure scores Dice 0."""
    if not records:
        raise ValueError("seed_stats needs at least one record")
    dice = np.array([0.0 if r.failed else r.dice for r in records])
    q = np.percentile(dice, [0, 25, 50, 75, 100])
    return SeedStats(len(records), sum(r.failed for r in records), float(q[2]), float(q[1]), float(q[3]),
                     float(q[0]), float(q[4]))


def median_ok(records: Sequence[Record], attr: str) -> float:
    """Median of ``attr`` over the records that succeeded (NaN if none did)."""
    values = [getattr(r, attr) for r in records if not r.failed]
    values = [v for v in values if math.isfinite(v)]
    return float(np.median(values)) if values else math.nan


def group(records: Iterable[Record], keys: Sequence[str]) -> dict[tuple, list[Record]]:
    """Records grouped by the values of label ``keys`` (and ``method`` if named), in first-seen order."""
    groups: dict[tuple, list[Record]] = {}
    for r in records:
        labels = {**r.job.labels, "method": r.job.method}
        groups.setdefault(tuple(labels[k] for k in keys), []).append(r)
    return groups


def pareto_front(times: Sequence[float], scores: Sequence[float]) -> list[int]:
    """Indices of the points no other point beats (time no larger and score no smaller), by time.

    Of points with equal time and score only the first is kept; NaN points are never on the front.
    """
    order = sorted((i for i in range(len(times)) if math.isfinite(times[i]) and math.isfinite(scores[i])),
                   key=lambda i: (times[i], -scores[i]))
    front: list[int] = []
    for i in order:
        if not front or scores[i] > scores[front[-1]]:
            front.append(i)
    return front


def breakdown_point(settings: Sequence, medians: Sequence[float], threshold: float = DICE_GOOD) -> object | None:
    """The first setting (``settings`` ordered from easy to hard) whose median Dice is below ``threshold``
    (NaN counts as below); None when the method holds up at every setting."""
    if len(settings) != len(medians):
        raise ValueError(f"settings ({len(settings)}) and medians ({len(medians)}) differ in length")
    for setting, median in zip(settings, medians):
        if not median >= threshold:
            return setting
    return None


def extrapolate_time(run_time_s: float, stages: dict, steps: int, short_stages: dict | None = None) -> float:
    """Run time if every optimisation stage ran ``steps`` steps; the time outside the stages (data, FBP,
    segmentation, metrics) is kept as measured. A stage stopped before its ``planned_steps`` (a
    race lost) is scaled to the same share of ``steps``.

    stages: metrics.json ``stages``, {name: {"steps", "planned_steps", "wall_time_s", ...}}. short_stages: the same of
    a run with fewer steps and otherwise the same settings: each stage's time per step is then the
    slope between the two, which leaves its fixed set-up cost out; without it (or where the slope is
    not positive) stage time / steps, an upper bound. NaN without usable stages.
    """
    timed = {k: s for k, s in stages.items() if isinstance(s, dict) and s.get("steps") and "wall_time_s" in s}
    if not timed or not math.isfinite(run_time_s):
        return math.nan
    total = run_time_s
    for name, stage in timed.items():
        n, t = int(stage["steps"]), float(stage["wall_time_s"])
        per_step, fixed = t / n, 0.0
        short = (short_stages or {}).get(name) or {}
        if short.get("wall_time_s") is not None and 0 <= int(short.get("steps", n)) < n:
            slope = (t - float(short["wall_time_s"])) / (n - int(short["steps"]))
            if slope > 0:
                per_step, fixed = slope, t - slope * n
        total += fixed + per_step * steps * n / int(stage.get("planned_steps", n)) - t
    return total
