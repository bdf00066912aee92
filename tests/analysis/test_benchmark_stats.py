"""What the benchmarks make of their records: Pareto fronts, breakdown points and extrapolation on
hand-made numbers."""

import math

import pytest

from nct.analysis.benchmark_stats import breakdown_point, extrapolate_time, pareto_front


def test_pareto_front_keeps_only_undominated_points_in_time_order():
    times = [10, 5, 20, 5, 30, math.nan, 1]
    scores = [0.8, 0.7, 0.9, 0.6, 0.85, 0.99, 0.5]
    assert pareto_front(times, scores) == [6, 1, 0, 2]
    assert pareto_front([1.0, 1.0, 2.0], [0.5, 0.5, 0.5]) == [0]
    assert pareto_front([], []) == []


def test_breakdown_point_is_the_first_setting_below_threshold():
    assert breakdown_point([0, 45, 90, 135], [0.95, 0.86, 0.84, 0.9]) == 90
    assert breakdown_point([1e6, 1e4, 1e3], [0.95, 0.85, 0.851]) is None
    assert breakdown_point([720, 360, 90], [0.9, math.nan, 0.9]) == 360
    assert breakdown_point([0, 1], [0.9, 0.7], threshold=0.6) is None
    with pytest.raises(ValueError, match="differ in length"):
        breakdown_point([0, 1], [0.9])


def test_extrapolated_time_scales_each_stage_and_keeps_the_rest():
    stages = {"init": {"steps": 10, "wall_time_s": 20.0, "losses": [1.0]}, "fit": {"steps": 20, "wall_time_s": 60.0}}
    assert extrapolate_time(100.0, stages, 5000) == pytest.approx(20.0 + 2.0 * 5000 + 3.0 * 5000)
    long, short = {"fit": {"steps": 100, "wall_time_s": 30.0}}, {"fit": {"steps": 10, "wall_time_s": 12.0}}
    assert extrapolate_time(50.0, long, 5000, short) == pytest.approx(50.0 - 30.0 + 10.0 + 0.2 * 5000)
    slower_short = {"fit": {"steps": 10, "wall_time_s": 40.0}}
    assert extrapolate_time(50.0, long, 5000, slower_short) == pytest.approx(50.0 - 30.0 + 0.3 * 5000)
    raced = stages | {"fit_start1": {"steps": 4, "planned_steps": 20, "wall_time_s": 12.0}}  # stopped at a fifth
    assert extrapolate_time(112.0, raced, 5000) == pytest.approx(20.0 + 2.0 * 5000 + 3.0 * 5000 + 3.0 * 1000)
    assert math.isnan(extrapolate_time(100.0, {}, 5000))
    assert math.isnan(extrapolate_time(math.nan, stages, 5000))
