"""benchmarks/phase_times.py: each wrapped call's own time goes to its phase, the phases add up to the
process's time, and every function it wraps is found in this version."""

from __future__ import annotations

import json

from tests.conftest import load_benchmark as load_script

phase_times = load_script("phase_times")


class FakeTime:
    """A clock that moves only when told (``spend``): wall and CPU seconds alike."""

    def __init__(self) -> None:
        self.now = 100.0

    def perf_counter(self) -> float:
        return self.now

    def process_time(self) -> float:
        return self.now - 90.0

    def spend(self, seconds: float) -> None:
        self.now += seconds


def test_a_call_counts_its_own_time_less_its_wrapped_callees(monkeypatch):
    fake = FakeTime()
    monkeypatch.setattr(phase_times, "time", fake)
    monkeypatch.setattr(phase_times, "ORIGIN", (fake.perf_counter(), fake.process_time()))
    clock = phase_times.PhaseClock()
    fake.spend(3.0)  # start-up
    inner = clock.wrap("inner", lambda: fake.spend(5.0))

    def outer() -> None:
        fake.spend(2.0)
        inner()
        inner()

    clock.wrap("outer", outer)()
    fake.spend(1.0)  # what no phase holds
    record = clock.record(["x=1"])
    assert record["wall_s"] == {"startup": 3.0, "outer": 2.0, "inner": 10.0, "other": 1.0}
    assert record["total_wall_s"] == 16.0 and record["cpu_s"]["startup"] == 13.0  # CPU from the process's start


def test_every_function_it_times_is_in_this_version():
    """A renamed pipeline function would send its time to 'other' unnoticed: the harness must find them all."""
    found, missing = phase_times.wrappers(phase_times.PhaseClock())
    assert missing == [] and len(found) == len(phase_times.PHASE_OF)


def test_compare_gives_each_phases_median_and_range(tmp_path):
    def record(path, cpu: float, wall: float):
        path.write_text(json.dumps({"argv": [], "load_1min": 2.0, "total_wall_s": wall + 1, "total_cpu_s": cpu + 1,
                                    "wall_s": {"startup": wall, "other": 1.0}, "cpu_s": {"startup": cpu, "other": 1.0}}))
        return path

    before = [record(tmp_path / f"b{i}.json", cpu, cpu + 2) for i, cpu in enumerate((5.0, 6.0, 7.0))]
    after = [record(tmp_path / f"a{i}.json", cpu, cpu + 2) for i, cpu in enumerate((3.0, 4.0, 4.5))]
    lines = phase_times.compare(before, after).splitlines()
    assert lines[2] == "| startup | 6.00 [5.00–7.00] | 4.00 [3.00–4.50] | 8.00 [7.00–9.00] | 6.00 [5.00–6.50] |"
    assert lines[4] == "| **whole process** | 7.00 [6.00–8.00] | 5.00 [4.00–5.50] | 9.00 [8.00–10.00] | 7.00 [6.00–7.50] |"
