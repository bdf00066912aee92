"""The run's stopwatch: phases as laps that add up, and the tournament split by its stages' own times."""

import time

import pytest

from nct.run.phases import Instant, Phases, breakdown, phase_table, stage_walls


def test_laps_add_up_to_the_time_since_the_start_and_a_phase_met_twice_adds():
    started = Instant.now()
    phases = Phases(started)
    for phase in ("data", "checks", "fit", "checks"):
        end = time.perf_counter() + 0.01
        while time.perf_counter() < end:  # busy: CPU time passes too
            pass
        phases.lap(phase)
    record = phases.record()
    assert list(record["wall_s"]) == list(record["cpu_s"]) == ["data", "checks", "fit"]
    assert record["wall_s"]["checks"] > record["wall_s"]["data"] >= 0.01  # two laps against one
    assert sum(record["wall_s"].values()) == pytest.approx(phases.last.wall - started.wall, abs=1e-9)
    assert all(v >= 0 for v in record["cpu_s"].values()) and sum(record["cpu_s"].values()) > 0.01


def test_breakdown_splits_the_tournament_into_its_fits_and_selection():
    wall = {"startup": 5.0, "initialisation": 2.0, "tournament": 30.0, "refinement": 4.0, "exports": 1.0}
    stages = {"free_init": 4.0, "free_fit": 20.0, "static_fit": 5.0, "refine_init": 1.0, "refine_fit": 2.5}
    assert breakdown(wall, stages) == {"startup": 5.0, "initialisation": 2.0, "fits": 29.0, "selection": 1.0,
                                       "refinement": 4.0, "exports": 1.0}
    # Stages loaded by resume keep their first run's times: no split that would make selection negative.
    assert breakdown(wall, {"free_fit": 31.0}) == wall
    assert breakdown({"fbp": 1.0}, {}) == {"fbp": 1.0}  # FBP alone: nothing to split


def test_stage_walls_skip_a_stage_without_a_time():
    stages = {"free_init": {"wall_time_s": 1.5, "steps": 3}, "band_fit": {"verdict": "diverged: loss is nan"}}
    assert stage_walls(stages) == {"free_init": 1.5}


def test_phase_table_lists_each_phase_the_fits_stages_and_the_total():
    record = {"wall_s": {"startup": 2.0, "tournament": 6.0, "exports": 2.0},
              "cpu_s": {"startup": 1.5, "tournament": 5.0, "exports": 1.0}}
    lines = phase_table(record, {"free_init": {"wall_time_s": 1.0}, "free_fit": {"wall_time_s": 4.0}}).splitlines()
    assert lines[0] == "| phase | wall s | CPU s | share of wall |"
    assert lines[2:] == ["| startup | 2 | 1.5 | 20 % |", "| fits | 5 | – | 50 % |", "| · free_init | 1 | – | – |",
                         "| · free_fit | 4 | – | – |", "| selection | 1 | – | 10 % |", "| exports | 2 | 1 | 20 % |",
                         "| total | 10 | 7.5 | 100 % |"]
