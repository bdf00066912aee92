"""Where one ``nct`` process's time goes, phase by phase, in wall and CPU seconds, for any version of nct.

The run's own record (metrics.json ``phases``) exists only in versions that write it; this harness
measures every version alike, so that an old and a new code can be compared: it runs ``nct`` in this
process with the pipeline's functions wrapped by name (`PHASE_OF`), each call's own time (less that of
the wrapped calls inside it) going to its phase. ``startup`` runs from this script's start (the
interpreter's own few tens of ms before it are not seen) to the first wrapped call, ``other`` is what
no phase holds (Hydra, seeding, the job's records, exit). CPU seconds are the whole process's
(``time.process_time``, every thread): on a shared machine they move less with the load than wall
seconds do.

Run: python benchmarks/phase_times.py --out FILE.json -- threads=1 logger=none hydra.run.dir=DIR
(the baseline: the same with its source tree first on PYTHONPATH).
"""

from __future__ import annotations

import time

ORIGIN = (time.perf_counter(), time.process_time())  # before any other import: start-up counts from here

import argparse  # noqa: E402
import atexit  # noqa: E402
import importlib  # noqa: E402
import json  # noqa: E402
import os  # noqa: E402
import sys  # noqa: E402
from collections.abc import Callable  # noqa: E402
from functools import wraps  # noqa: E402
from pathlib import Path  # noqa: E402

#: (module, function, phase): the functions whose calls make up each phase, in the order a run meets them.
PHASE_OF = (
    ("nct.run.pipeline", "acquire", "data"), ("nct.run.pipeline", "save_sinogram", "data"),
    ("nct.run.pipeline", "motion_determinacy", "checks"), ("nct.run.pipeline", "check_geometry", "checks"),
    ("nct.run.pipeline", "fbp_frames", "fbp"),
    ("nct.method.reconstruct", "prepare", "initialisation"),
    ("nct.method.reconstruct", "find_starts", "initialisation"),
    ("nct.method.reconstruct", "_tournament", "tournament"),
    ("nct.method.reconstruct", "reconstruct", "refinement"),  # its own time: the winner refined, its frames drawn
    ("nct.run.pipeline", "suspect_fit", "checks"),
    ("nct.run.pipeline", "frame_metrics", "metrics"), ("nct.run.pipeline", "summarise", "metrics"),
    ("nct.run.pipeline", "score_trace", "metrics"),
    ("nct.run.pipeline", "write_outputs", "exports"),
    ("nct.run.pipeline", "write_summary", "tensorboard"),  # after the run's wall time: TensorBoard's summary
)


class PhaseClock:
    """Wall and CPU seconds per phase: each wrapped call's own time (its time less its wrapped callees')."""

    def __init__(self) -> None:
        self.wall: dict[str, float] = {}
        self.cpu: dict[str, float] = {}
        self.first: tuple[float, float] | None = None
        self._inner: list[list[float]] = []  # per open call: its wrapped callees' [wall, cpu]

    def wrap(self, phase: str, fn: Callable) -> Callable:
        @wraps(fn)
        def timed(*args, **kwargs):
            start = (time.perf_counter(), time.process_time())
            self.first = self.first or start
            self._inner.append([0.0, 0.0])
            try:
                return fn(*args, **kwargs)
            finally:
                inner = self._inner.pop()
                spent = (time.perf_counter() - start[0], time.process_time() - start[1])
                self.wall[phase] = self.wall.get(phase, 0.0) + spent[0] - inner[0]
                self.cpu[phase] = self.cpu.get(phase, 0.0) + spent[1] - inner[1]
                if self._inner:
                    self._inner[-1][0] += spent[0]
                    self._inner[-1][1] += spent[1]
        return timed

    def record(self, argv: list[str]) -> dict:
        """The phases in run order, ``startup`` first and ``other`` last, with the process's totals."""
        total = (time.perf_counter() - ORIGIN[0], time.process_time())
        first = self.first or (time.perf_counter(), time.process_time())
        wall = {"startup": first[0] - ORIGIN[0], **self.wall}
        cpu = {"startup": first[1], **self.cpu}
        wall["other"], cpu["other"] = total[0] - sum(wall.values()), total[1] - sum(cpu.values())
        return {"argv": argv, "load_1min": os.getloadavg()[0], "total_wall_s": total[0], "total_cpu_s": total[1],
                "wall_s": wall, "cpu_s": cpu}


def wrappers(clock: PhaseClock) -> tuple[list[tuple[object, str, Callable]], list[str]]:
    """Each function of `PHASE_OF` this version has, as (module, name, its timed wrapper); and those it lacks."""
    found, missing = [], []
    for module_name, name, phase in PHASE_OF:
        module = importlib.import_module(module_name)
        if hasattr(module, name):
            found.append((module, name, clock.wrap(phase, getattr(module, name))))
        else:
            missing.append(f"{module_name}.{name}")
    return found, missing


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, required=True, help="the JSON record to write")
    parser.add_argument("overrides", nargs="*", help="nct's overrides (after --)")
    args = parser.parse_args()
    clock = PhaseClock()
    found, missing = wrappers(clock)
    for module, name, timed in found:
        setattr(module, name, timed)
    if missing:
        print(f"phase_times: this version lacks {', '.join(missing)}: their time goes to 'other'", file=sys.stderr)

    def write() -> None:
        record = clock.record(args.overrides)
        args.out.write_text(json.dumps(record, indent=2))
        for phase, wall in record["wall_s"].items():
            print(f"{phase:>15}: wall {wall:7.2f} s  CPU {record['cpu_s'][phase]:7.2f} s", file=sys.stderr)

    atexit.register(write)
    from nct.cli.main import main as nct_main

    sys.argv = ["nct", *args.overrides]
    nct_main()


if __name__ == "__main__":
    main()
