"""Where one ``nct`` process's time goes, phase by phase, in wall and CPU seconds, for any version of nct.

The run's own record (metrics.json ``phases``) exists only in versions that write it; this harness
measures every version alike, so that an old and a new code can be compared: it runs ``nct`` in this
process with the pipeline's functions wrapped by name (`PHASE_OF`), each call's own time (less that of
the wrapped calls inside it) going to its phase. ``startup`` runs from this script's start (the
interpreter's own few tens of ms before it are not seen) to the first wrapped call, ``other`` is what
no phase holds (Hydra, seeding, the job's records, exit). CPU seconds are the whole process's
(``time.process_time``, every thread): on a shared machine they move less with the load than wall
seconds do.

Run: python benchmarks/phase_times.py --out FILE.json -- threads=1 hydra.run.dir=DIR
     (another version: the same with its source tree first on PYTHONPATH)
     python benchmarks/phase_times.py --before B1.json B2.json ... --after A1.json A2.json ...
     (a markdown table of the records: median and range per phase)
"""

from __future__ import annotations

import time

ORIGIN = (time.perf_counter(), time.process_time())  # before any other import: start-up counts from here

import argparse  # noqa: E402
import atexit  # noqa: E402
import importlib  # noqa: E402
import json  # noqa: E402
import os  # noqa: E402
import statistics  # noqa: E402
import sys  # noqa: E402
from collections.abc import Callable  # noqa: E402
from functools import wraps  # noqa: E402
from pathlib import Path  # noqa: E402

#: (module, function, phase): the functions whose calls make up each phase, in the order a run meets them.
PHASE_OF = (
    ("nct.run.pipeline", "acquire", "data"), ("nct.run.pipeline", "save_sinogram", "data"),
    ("nct.run.reconstruct", "motion_determinacy", "checks"), ("nct.run.reconstruct", "check_geometry", "checks"),
    ("nct.run.reconstruct", "fbp_frames", "fbp"),
    ("nct.select.scene", "prepare", "initialisation"),  # each scene model's set-up, then the race
    ("nct.select.scene", "sought", "initialisation"),
    ("nct.select.scene", "search", "initialisation"),
    ("nct.method.reconstruct", "race", "tournament"),
    ("nct.method.reconstruct", "reconstruct", "refinement"),  # its own time: the winner refined, its frames drawn
    ("nct.run.reconstruct", "suspect_fit", "checks"),
    ("nct.run.reconstruction", "frame_metrics", "metrics"), ("nct.run.pipeline", "summarise", "metrics"),
    ("nct.run.pipeline", "score_trace", "metrics"), ("nct.run.pipeline", "frame_metrics", "metrics"),
    ("nct.run.pipeline", "write_outputs", "exports"),
    ("nct.run.pipeline", "write_summary", "tensorboard"),  # after the run's wall time: TensorBoard's summary
)
#: The same steps under the names earlier versions gave them (39a9e4b; the pipeline before the Python API),
#: timed where those versions run.
EARLIER = (
    ("nct.method.reconstruct", "prepare", "initialisation"),
    ("nct.method.reconstruct", "find_starts", "initialisation"),
    ("nct.method.reconstruct", "_tournament", "tournament"),
    ("nct.run.pipeline", "motion_determinacy", "checks"), ("nct.run.pipeline", "check_geometry", "checks"),
    ("nct.run.pipeline", "fbp_frames", "fbp"), ("nct.run.pipeline", "suspect_fit", "checks"),
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
    """Each function of `PHASE_OF` (or `EARLIER`) this version has, as (module, name, its timed wrapper); and
    those of `PHASE_OF` it lacks."""
    found, missing = [], []
    for module_name, name, phase in (*PHASE_OF, *EARLIER):
        try:
            module = importlib.import_module(module_name)
        except ModuleNotFoundError:  # a package of another version
            module = None
        if hasattr(module, name):
            found.append((module, name, clock.wrap(phase, getattr(module, name))))
        elif (module_name, name, phase) in PHASE_OF:
            missing.append(f"{module_name}.{name}")
    return found, missing


def compare(before: list[Path], after: list[Path]) -> str:
    """Records of two versions (several runs each) as a markdown table: each phase's median CPU and wall
    seconds [range] before and after, the process's totals and the machine's load."""
    runs = {"before": [json.loads(p.read_text()) for p in before], "after": [json.loads(p.read_text()) for p in after]}

    def cell(version: str, kind: str, phase: str) -> str:
        values = [r[kind].get(phase, 0.0) for r in runs[version]]
        return f"{statistics.median(values):.2f} [{min(values):.2f}–{max(values):.2f}]"

    phases = list(dict.fromkeys(p for rs in runs.values() for r in rs for p in r["wall_s"]))
    lines = ["| phase | CPU s before | CPU s after | wall s before | wall s after |", "|---|---|---|---|---|"]
    lines += [f"| {p} | {cell('before', 'cpu_s', p)} | {cell('after', 'cpu_s', p)} | {cell('before', 'wall_s', p)} "
              f"| {cell('after', 'wall_s', p)} |" for p in phases]
    for version in runs:  # the totals as phases of their own
        for r in runs[version]:
            r["cpu_s"]["total"], r["wall_s"]["total"] = r["total_cpu_s"], r["total_wall_s"]
    lines.append(f"| **whole process** | {cell('before', 'cpu_s', 'total')} | {cell('after', 'cpu_s', 'total')} "
                 f"| {cell('before', 'wall_s', 'total')} | {cell('after', 'wall_s', 'total')} |")
    loads = [f"{r['load_1min']:.1f}" for rs in runs.values() for r in rs]
    return "\n".join(lines) + f"\n\nLoad (1-minute average) at each run's end: {', '.join(loads)}.\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, help="the JSON record to write")
    parser.add_argument("--before", type=Path, nargs="+", help="records to compare (no run): one version's ...")
    parser.add_argument("--after", type=Path, nargs="+", help="... and the other's")
    parser.add_argument("overrides", nargs="*", help="nct's overrides (after --)")
    args = parser.parse_args()
    if args.before or args.after:
        print(compare(args.before or [], args.after or []))
        return
    if args.out is None:
        parser.error("--out FILE (a run) or --before/--after FILE... (a comparison) is required")
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
