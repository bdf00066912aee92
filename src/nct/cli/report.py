"""The ``nct-report`` command: `nct.analysis.report.write_report` over a multirun folder, errors in one line."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

from nct.analysis.jobs import ReportError
from nct.analysis.report import write_report
from nct.run.outcome import FINISHED

HELP = """\
Summarise a Hydra multirun folder (a sweep, finished or interrupted) in DIR/report (or --out):
  report.csv   one row per job: overrides, status, error, wall time, metrics
  summary.md   counts, tables by swept setting, every job, what did not finish and
               the command that runs it again
  *.png        Dice and MSE against the swept setting, the TV-weight grid, accuracy
               against wall time, held-out loss against Dice (those that apply)
Failed, diverged, unfinished and never-started jobs are rows like the others."""


def main(argv: Sequence[str] | None = None) -> int:
    """Console entry point (``nct-report DIR [--out OUT]``); exit 2 on a bad DIR."""
    parser = argparse.ArgumentParser(prog="nct-report", description=HELP,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("dir", type=Path, help="a multirun folder (hydra.sweep.dir), e.g. outputs/multirun/...")
    parser.add_argument("--out", type=Path, default=None, help="where to write (default: DIR/report)")
    args = parser.parse_args(argv)
    try:
        report = write_report(args.dir, args.out)
    except ReportError as err:
        print(f"nct-report: error: {err}", file=sys.stderr)
        return 2
    not_ok = sum(j.status != FINISHED for j in report.jobs)
    print(f"{len(report.jobs)} jobs ({not_ok} not ok): {report.csv}, {report.summary}, "
          f"{len(report.plots)} plots in {report.csv.parent}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
