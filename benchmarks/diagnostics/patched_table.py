"""A generalisation table (``scenes.csv``) with the scenes a change touches replaced by a later call's rows, and
both tables' summaries: the median NCT Dice, the runs that fitted the scene's own model (K objects, no
background) and K, those below FBP's Dice by more than generalisation.MARGIN, those whose MSE is above FBP's. For
a change that touches a few scenes of a 100-scene call (``--only`` those scenes) whose folder is no longer there.

    python benchmarks/diagnostics/patched_table.py BASE/scenes.csv AFTER/scenes.csv --out OUT
"""

from __future__ import annotations

import argparse
import csv
import statistics
import sys
from collections.abc import Sequence
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from generalisation import MARGIN  # noqa: E402

from nct.run.tables import markdown_table, write_csv  # noqa: E402


def read(path: Path) -> dict[str, dict[str, str]]:
    """A generalisation table's rows by scene."""
    with open(path, newline="") as fh:
        return {row["scene"]: row for row in csv.DictReader(fh)}


def read_all(parser: argparse.ArgumentParser, *paths: Path) -> list[dict[str, dict[str, str]]]:
    """Each of ``paths`` `read`, or the ``parser``'s one-line error naming the first that is not a file."""
    missing = [p for p in paths if not p.is_file()]
    if missing:
        parser.error(f"no table at {missing[0]}")
    return [read(p) for p in paths]


def cell(text: str) -> float | str:
    """A table's text as a number where it is one (markdown_table then rounds it)."""
    try:
        return float(text)
    except ValueError:
        return text


def summary(rows: dict[str, dict[str, str]]) -> list:
    """scenes, median NCT Dice, own model, own K, below FBP - MARGIN (named), MSE above FBP's (named)."""
    below = [s for s, r in rows.items() if float(r["nct_dice"]) < float(r["fbp_dice"]) - MARGIN]
    worse = [s for s, r in rows.items() if float(r["nct_mse"]) > float(r["fbp_mse"])]
    return [len(rows), f"{statistics.median(float(r['nct_dice']) for r in rows.values()):.4f}",
            sum(r["model_right"] == "True" for r in rows.values()),
            sum(r["chosen_k"] == r["n_objects"] for r in rows.values()),
            " ".join(below) or "none", " ".join(worse) or "none"]


def report(base: dict, after: dict, command: str) -> str:
    """The note: both summaries, then each replaced scene before and after."""
    patched = base | after
    head = ["table", "scenes", "median NCT Dice", "own model", "own K", f"below FBP - {MARGIN:g}", "MSE above FBP's"]
    totals = markdown_table(head, [["base", *summary(base)], ["patched", *summary(patched)]])
    cols = ("winner", "chosen_k", "nct_dice", "nct_mse", "wall_time_s")
    scenes = markdown_table(
        ["scene", "K", *[f"{c} before" for c in cols], *[f"{c} after" for c in cols], "FBP Dice", "FBP MSE"],
        [[s, base[s]["n_objects"], *[cell(base[s][c]) for c in cols], *[cell(r[c]) for c in cols], cell(r["fbp_dice"]),
          cell(r["fbp_mse"])]
         for s, r in sorted(after.items()) if s in base])
    return "\n".join(["# A generalisation table patched with the scenes a change touches", "",
                      f"Command: `{command}`", "", totals, "", scenes, ""])


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("base", type=Path, help="the whole call's scenes.csv")
    parser.add_argument("after", type=Path, help="the later call's scenes.csv (its scenes replace the base's)")
    parser.add_argument("--out", type=Path, required=True, help="folder for scenes.csv (patched) and README.md")
    args = parser.parse_args(argv)
    base, after = read_all(parser, args.base, args.after)
    if not after.keys() <= base.keys():
        parser.error(f"scenes not in the base table: {' '.join(sorted(after.keys() - base.keys()))}")
    args.out.mkdir(parents=True, exist_ok=True)
    patched = base | after
    write_csv(list(patched.values()), args.out / "scenes.csv")
    command = "python benchmarks/diagnostics/patched_table.py " + " ".join(sys.argv[1:] if argv is None else argv)
    (args.out / "README.md").write_text(report(base, after, command))
    print(f"wrote {args.out / 'README.md'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
