"""benchmarks/bench_fields.py: every rung of both field families runs the method's own SinogramFit stage for the
steps asked (the script had rotted once against the stage's signature, unseen)."""

from __future__ import annotations

import pytest

from nct.fields.conf import RUNGS
from tests.conftest import load_benchmark as load_script

bench_fields = load_script("bench_fields")


@pytest.mark.parametrize("family", bench_fields.FAMILIES)
def test_every_rung_runs_the_stage_for_the_steps_asked(family):
    counts = {}
    for rung in RUNGS:
        n_params, seconds, steps = bench_fields.stage_seconds(family, rung, 16, 4, 3, 8)
        assert steps == 3 and seconds > 0, (rung, steps, seconds)
        counts[rung] = n_params
    assert counts["static"] < counts["free"] and counts["rigid"] < counts["free"], counts
