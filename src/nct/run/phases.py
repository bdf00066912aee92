"""Where a run's time goes: wall and CPU seconds per phase of one job (metrics.json ``phases``).

The phases are laps of one stopwatch that starts with the job (a single run's with its process), so
they add up to the job's wall time and nothing goes unaccounted: ``startup`` (imports, Hydra, the
config), ``data`` (simulated or read, and saved), ``checks`` (motion determinacy, geometry, and after
the fit the held-out misfits of the warnings), ``fbp``, ``initialisation`` (units, views, FBP frames of
the starts, segmentation, judge, SDFs), ``tournament`` (every candidate fitted and chosen),
``refinement`` (the winner refined, its frames drawn), ``metrics`` and ``exports``. Each stage's own time
is in metrics.json ``stages``; `breakdown` splits the tournament with it.
"""

from __future__ import annotations

import time
from collections.abc import Mapping
from dataclasses import dataclass, field

from nct.run.tables import markdown_table

#: The stages the winner's refinement runs (method/reconstruct.py): counted in ``refinement``, not the tournament.
REFINE_PREFIX = "refine_"


@dataclass(frozen=True)
class Instant:
    """A moment of this process: its wall clock (``time.perf_counter``) and the CPU seconds it has used
    so far (``time.process_time``, all its threads)."""

    wall: float
    cpu: float

    @classmethod
    def now(cls) -> Instant:
        return cls(time.perf_counter(), time.process_time())


@dataclass
class Phases:
    """One job's stopwatch: `lap` ends a phase; ``wall`` and ``cpu`` hold each phase's seconds, in the
    order the job met them (a phase met twice adds up)."""

    last: Instant
    wall: dict[str, float] = field(default_factory=dict)
    cpu: dict[str, float] = field(default_factory=dict)

    def lap(self, phase: str) -> None:
        """The time since the last lap (or the job's start) was spent in ``phase``."""
        now = Instant.now()
        self.wall[phase] = self.wall.get(phase, 0.0) + now.wall - self.last.wall
        self.cpu[phase] = self.cpu.get(phase, 0.0) + now.cpu - self.last.cpu
        self.last = now

    def record(self) -> dict[str, dict[str, float]]:
        """metrics.json ``phases``: ``wall_s`` and ``cpu_s``, seconds by phase."""
        return {"wall_s": dict(self.wall), "cpu_s": dict(self.cpu)}


def breakdown(wall: Mapping[str, float], stage_walls: Mapping[str, float]) -> dict[str, float]:
    """The phases' seconds ``wall`` with the tournament split in two: ``fits`` (its stages' own time, each
    candidate's InitFit and SinogramFit: ``stage_walls``, by stage name, from metrics.json ``stages``) and
    ``selection`` (the rest: scoring candidates on the check views, keeping their weights, choosing). Left
    whole where its stages took longer than it did (stages loaded by ``resume`` keep their first run's times)."""
    fits = sum(s for name, s in stage_walls.items() if not name.startswith(REFINE_PREFIX))
    out: dict[str, float] = {}
    for phase, seconds in wall.items():
        if phase == "tournament" and fits <= seconds:
            out |= {"fits": fits, "selection": seconds - fits}
        else:
            out[phase] = seconds
    return out


def stage_walls(stages: Mapping[str, Mapping]) -> dict[str, float]:
    """Each stage's wall seconds from metrics.json ``stages`` (a stage that diverged has none)."""
    return {name: float(s["wall_time_s"]) for name, s in stages.items() if "wall_time_s" in s}


def phase_table(record: Mapping[str, Mapping[str, float]], stages: Mapping[str, Mapping]) -> str:
    """A run's phases (metrics.json ``phases``) as a markdown table: each phase's wall and CPU seconds and
    share of the wall time, the tournament split into its fits, a row per stage, and selection (`breakdown`)."""
    wall, cpu = record["wall_s"], record["cpu_s"]
    walls = stage_walls(stages)
    total = sum(wall.values())
    rows = []
    for phase, seconds in breakdown(wall, walls).items():
        rows.append([phase, seconds, cpu.get(phase), f"{100 * seconds / total:.0f} %" if total > 0 else None])
        if phase == "fits":
            rows += [[f"· {name}", s, None, None] for name, s in walls.items() if not name.startswith(REFINE_PREFIX)]
    rows.append(["total", total, sum(cpu.values()), "100 %"])
    return markdown_table(["phase", "wall s", "CPU s", "share of wall"], rows)
