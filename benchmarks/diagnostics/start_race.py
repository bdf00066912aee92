"""What the start race (``init.race_at``, ``init.race_gain``) decides on a generalisation call's
runs, from the held-out histories of each pass's leader and its runner-up starts, and the time it saves.

A runner-up the race stops leaves the run bit for bit as with the leader alone, and one it lets go
on is not touched, so on a call whose runner-ups all ran to the end (``--override
init.race_gain=1e9``) the outcome of any rule follows from the stage records alone
(``metrics.json`` -> ``stages``: ``<pass>fit`` and its retries, the leader's; ``<pass>fit_start<n>``,
a runner-up's). Written by hand: no library replays a stopping rule on logged curves.

    python benchmarks/diagnostics/start_race.py --call outputs/benchmarks/gen_seed1_full --at 0.1 0.2 0.3 --gain 1.0 1.1
"""

from __future__ import annotations

import json
import re
import sys
from dataclasses import dataclass
from pathlib import Path

from band_race import history, replay_args, rule_row
from omegaconf import OmegaConf

from nct.method.conf import InitConf
from nct.method.race import HeldoutHistory, lost, race

RUNNER_UP = re.compile(r"^(?P<prefix>.*)fit_start(?P<n>\d+)$")


@dataclass(frozen=True)
class Challenge:
    """One runner-up start's fit against its pass's leader, as run."""

    scene: str
    stage: str
    leader: HeldoutHistory
    runner_up: HeldoutHistory
    steps: int
    leader_end: float
    runner_up_end: float
    ran_to: int  # the step the runner-up's fit stopped at (``steps`` where it ran to the end)
    fit_time: float
    kept: bool


def challenges(run: Path, scene: str) -> list[Challenge]:
    """The runner-up fits of a run's passes (none where it had one start)."""
    stages = json.loads((run / "metrics.json").read_text())["stages"]
    steps = int(OmegaConf.load(run / ".hydra" / "config.yaml").optim.fit_steps)  # a raced fit may have run fewer
    found = []
    for name, record in stages.items():
        match = RUNNER_UP.match(name)
        if not match:
            continue
        prefix = match["prefix"]
        attempts = [n for n in stages if re.fullmatch(re.escape(prefix) + r"fit(_retry\d+)?", n)]
        leader = min(attempts, key=lambda n: stages[n]["misfit_end"])
        mine = history(run, stages, name)
        found.append(Challenge(scene, name, history(run, stages, leader), mine, steps, stages[leader]["misfit_end"],
                               record["misfit_end"], int(record["steps"]), float(record["wall_time_s"]),
                               bool(record.get("kept"))))
    return found


def main(argv: list[str] | None = None) -> int:
    args = replay_args(argv, __doc__, InitConf().race_at, InitConf().race_gain)
    found, run_times = [], {}
    for metrics in sorted(args.call.glob("runs/*/nct/metrics.json")):
        scene = metrics.parent.parent.name
        mine = challenges(metrics.parent, scene)
        found += mine
        if mine:
            run_times[scene] = float(json.loads(metrics.read_text())["wall_time_s"])
    if not found:
        print(f"start_race: error: no finished run in {args.call}/runs fitted a runner-up start", file=sys.stderr)
        return 1
    print(f"{len(found)} runner-up fits in {len(run_times)} runs; each line: the runner-up's held-out loss over "
          "the leader's at each check, its misfit at the end over the leader's, and whether it was kept")
    for c in found:
        lead = dict(c.leader)
        print(f"  {c.scene} {c.stage}: " + " ".join(f"{loss / lead[s]:.2f}" for s, loss in c.runner_up if s in lead)
              + f"  end {c.runner_up_end / c.leader_end:.2f}" + ("  kept" if c.kept else ""))
    spent = {s: sum(c.fit_time for c in found if c.scene == s) for s in run_times}
    print("| race_at | race_gain | runner-ups stopped | kept ones stopped | saved of the runner-ups' time "
          "| run / run without runner-ups, median: as run -> with this rule |")
    print("|---|---|---|---|---|---|")
    for at in args.at:
        for gain in args.gain:
            stopped, lost_keeps, saved = 0, [], {s: 0.0 for s in run_times}
            for c in found:
                verdict = race(c.runner_up, c.leader, c.steps, at, gain)
                if lost(verdict) and verdict["step"] < c.ran_to:
                    stopped += 1
                    saved[c.scene] += (1 - verdict["step"] / c.ran_to) * c.fit_time
                    lost_keeps += [f"{c.scene} {c.stage}"] if c.kept else []
            print(rule_row(at, gain, [f"{stopped}/{len(found)}", ", ".join(lost_keeps) or "none"],
                           [(run_times[s], spent[s], saved[s]) for s in run_times]))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
