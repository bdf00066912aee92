"""The suspect-fit warning's limit (``suspect.fbp_ratio``) against the truth, over any finished runs on disk.

Every ``metrics.json`` below the given folders that holds the held-out misfits (NCT's, FBP's, the noise's) and the
truth's scores gives one run: its ratio beyond the noise, (NCT - noise) / (FBP - noise), what it leaves unexplained,
NCT - noise (``suspect.excess``'s measure), and whether it is poor by the warnings benchmark's definition
(benchmarks/warning_rates.py: Dice below FBP's - MARGIN or below POOR_DICE, or MSE above FBP's; the medians over
frames). Runs whose misfits are equal to the digit are one run (a folder copied, or rerun to the bit). For each limit:
the runs the ratio line warns (above it), those of them that are not poor (false alarms), the poor ones and those of
them it leaves quiet (misses), alone and with the excess line beside it.

Run: python benchmarks/diagnostics/suspect_limit.py DIR [DIR ...] [--limits 1 1.25 1.5] [--out OUT]
"""

from __future__ import annotations

import argparse
import json
import sys
from dataclasses import asdict, dataclass
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from warning_rates import MARGIN, POOR_DICE  # noqa: E402

from nct.run.conf import SuspectConf  # noqa: E402
from nct.run.tables import markdown_table, write_csv  # noqa: E402


@dataclass(frozen=True)
class Scored:
    """One run: ``ratio`` and ``excess`` of its held-out misfit beyond the noise; NCT's and FBP's median Dice, MSE."""

    run: str
    ratio: float
    excess: float
    nct_dice: float
    fbp_dice: float
    nct_mse: float
    fbp_mse: float

    @property
    def poor(self) -> bool:
        return self.nct_dice < self.fbp_dice - MARGIN or self.nct_dice < POOR_DICE or self.nct_mse > self.fbp_mse


def read_runs(folders: list[Path]) -> list[Scored]:
    """The scored runs below ``folders``, one per distinct pair of misfits, in path order."""
    runs, seen = [], set()
    for path in sorted(p for f in folders for p in f.rglob("metrics.json")):
        m = json.loads(path.read_text())
        misfits = (m.get("heldout_loss"), m.get("heldout_fbp_loss"), m.get("heldout_noise_loss"))
        if None in misfits or "nct" not in m or "fbp" not in m or misfits[:2] in seen:
            continue
        seen.add(misfits[:2])
        nct, fbp, noise = misfits
        runs.append(Scored(str(path.parent), (nct - noise) / max(fbp - noise, 1e-30), nct - noise,
                           m["nct"]["median_dice"], m["fbp"]["median_dice"], m["nct"]["median_mse"],
                           m["fbp"]["median_mse"]))
    return runs


def tally(runs: list[Scored], limit: float, excess: float) -> list[dict]:
    """For the ratio line at ``limit``, alone and with the excess line at ``excess``: warned, false alarms,
    poor runs and misses."""
    rows = []
    for lines, warns in (("ratio", lambda r: r.ratio > limit),
                         ("ratio or excess", lambda r: r.ratio > limit or r.excess > excess)):
        warned = [r for r in runs if warns(r)]
        poor = [r for r in runs if r.poor]
        rows.append({"limit": limit, "lines": lines, "runs": len(runs), "warned": len(warned),
                     "false alarms": sum(not r.poor for r in warned), "poor": len(poor),
                     "misses": sum(not warns(r) for r in poor)})
    return rows


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("folders", nargs="+", type=Path)
    parser.add_argument("--limits", nargs="+", type=float, default=[1.0, 1.25, 1.5, 2.0])
    parser.add_argument("--out", type=Path, default=Path("outputs/suspect_limit"))
    args = parser.parse_args(argv)
    runs = read_runs(args.folders)
    excess = SuspectConf().excess
    table = [row for limit in args.limits for row in tally(runs, limit, excess)]
    args.out.mkdir(parents=True, exist_ok=True)
    write_csv([asdict(r) | {"poor": r.poor} for r in runs], args.out / "runs.csv")
    near = sorted((r for r in runs if min(args.limits) / 2 < r.ratio <= 2 * max(args.limits)), key=lambda r: r.ratio)
    text = (f"# The suspect-fit limit over {len(runs)} runs (excess line at {excess:g})\n\n"
            + markdown_table(list(table[0]), [list(row.values()) for row in table])
            + "\n\n## The runs near the limits\n\n"
            + markdown_table(["run", "ratio", "excess", "NCT / FBP Dice", "NCT / FBP MSE", "poor"],
                             [[r.run, f"{r.ratio:.2f}", f"{r.excess:.3f}", f"{r.nct_dice:.3f} / {r.fbp_dice:.3f}",
                               f"{r.nct_mse:.2e} / {r.fbp_mse:.2e}", r.poor] for r in near]) + "\n")
    (args.out / "suspect_limit.md").write_text(text)
    print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
