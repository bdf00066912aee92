"""A generalisation call with nothing passed against one told each scene's model (issue 47, bar 2): the median Dice
of both over the scenes they share (a failed run's 0), the scene model each run chose, and what a model other than
the truth's cost (Dice and MSE against the told run's and FBP's), from the two calls' ``scenes.csv``.

    python benchmarks/diagnostics/against_told.py TOLD/scenes.csv NOTHING_PASSED/scenes.csv --out FILE.md
"""

from __future__ import annotations

import argparse
import statistics
import sys
from collections.abc import Sequence
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from generalisation import MARGIN  # noqa: E402
from patched_table import read_all  # noqa: E402

from nct.run.tables import markdown_table  # noqa: E402

LOSS = 0.005  # a Dice change beyond this is a loss or a gain (issue 47's bar: the median within it of told's)


def dice(row: dict[str, str]) -> float:
    """A row's NeuralCT Dice, a failed run's 0 (as the benchmark counts it)."""
    return float(row["nct_dice"]) if row["nct_status"] == "ok" else 0.0


def summary(told: dict, chosen: dict) -> list[list]:
    """The shared scenes' medians, losses and gains over LOSS, scenes below FBP - MARGIN, and the models chosen."""
    shared = [s for s in chosen if s in told]
    change = {s: dice(chosen[s]) - dice(told[s]) for s in shared}
    below = [s for s in shared if chosen[s]["below_fbp"] == "True"]  # the benchmark's verdict (generalisation.py)
    right = sum(chosen[s]["model_right"] == "True" for s in shared)
    held = sum(chosen[s].get("model_equivalent") == "True" for s in shared) - right
    medians = [statistics.median(dice(table[s]) for s in shared) for table in (chosen, told)]
    return [["scenes", len(shared)],
            ["median Dice, nothing passed / told", " / ".join(f"{m:.4f}" for m in medians)],
            [f"losses / gains over {LOSS:g}", f"{sum(c < -LOSS for c in change.values())} / "
             f"{sum(c > LOSS for c in change.values())}"],
            [f"below FBP - {MARGIN:g}, nothing passed", " ".join(below) or "none"],
            ["the truth's model (K ellipses, no background)", right],
            ["its moving ellipses over an image holding the still ones", held]]


def differing(told: dict, chosen: dict) -> list[list]:
    """One row per shared scene whose run chose a model other than the truth's: what it chose and what it cost."""
    return [[s, r["motions"], r["winner"], r["chosen_k"], r["chosen_background"],
             f"{dice(r) - dice(told[s]):+.4f}", dice(r), dice(told[s]), float(r["fbp_dice"]), float(r["nct_mse"]),
             float(told[s]["nct_mse"]), float(r["fbp_mse"])]
            for s, r in sorted(chosen.items()) if s in told and r["model_right"] != "True"]


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("told", type=Path, help="scenes.csv of a call told each scene's model (--told)")
    parser.add_argument("chosen", type=Path, help="scenes.csv of a call with nothing passed")
    parser.add_argument("--out", type=Path, required=True, help="the markdown note to write")
    args = parser.parse_args(argv)
    told, chosen = read_all(parser, args.told, args.chosen)
    if "model_right" not in next(iter(chosen.values()), {}):
        parser.error(f"{args.chosen} has no model_right column: not a call with nothing passed")
    command = "python benchmarks/diagnostics/against_told.py " + " ".join(sys.argv[1:] if argv is None else argv)
    rows = differing(told, chosen)
    args.out.write_text("\n".join([
        "# Nothing passed against told", "", f"Command: `{command}`", "",
        markdown_table(["", "value"], summary(told, chosen)), "",
        f"The {len(rows)} shared scenes whose run chose a model other than the truth's:", "",
        markdown_table(["scene", "motions", "chosen", "K", "background", "Dice change", "Dice", "told", "FBP", "MSE",
                        "told MSE", "FBP MSE"], rows), ""]))
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
