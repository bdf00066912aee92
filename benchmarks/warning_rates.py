"""Warnings as a classifier (issue 50): per warning kind, the warned runs that were fine (false alarms)
and the runs that deserved it but went unwarned (misses), over benchmark folders whose truth is known.

nct's warnings (status.json ``warnings``) are truth-free; this benchmark reads the truth each folder
holds: the generalisation benchmark's (``scenes.csv``: the scene's motions, deg/rot per object,
rotations, gantry sense, noise; NCT's and FBP's median Dice and MSE from each run's metrics.json) or
the textured one's (``textured.csv``: the moving objects' kinds; Dice: the worst moving object's at
its own level). Status and warnings come from each run's folder, ``runs/<scene>/nct`` (generalisation)
or ``runs/<scene>/<background>`` (textured). A warning line's kind is told by the phrase its function
writes (`KINDS`; unknown lines count as ``other``). When a warning is justified:

- a poor fit: NCT Dice < FBP Dice - 0.01 (generalisation's criterion (b)), NCT Dice < 0.8, or NCT MSE
  above FBP's;
- ``times`` (acquisition/times.py): the file's times are not in seconds: the benchmarks' files hold
  seconds (scene_files.py), so never: any is a false alarm;
- ``motion`` (moments/determinacy.py): an object's centre moves (orbit or translation: motion along
  the rays) and the fit is poor;
- ``turn`` (moments/determinacy.py): an object turns (rotation) whose own frame the views cover over
  less than 180 deg (rotations x |360 x gantry sense - its deg/rot|) and the fit is poor;
- ``offset``, ``fan`` (run/consistency.py): the file's geometry was written wrong: never on these
  benchmarks (exact parallel beam, centred detector), so any is a false alarm;
- ``suspect_fbp``, ``suspect_excess`` (run/suspect.py): the fit is poor.

Per kind (and per group of kinds, and any warning against a poor fit), over the runs that finished
(a failed run warns nothing; it is listed, not scored): false-alarm rate = warned but not justified /
warned; miss rate = justified but not warned / justified. Writes warnings.csv (one row per run) and
warnings.md.

Run: python benchmarks/warning_rates.py DIR [DIR ...] [--out OUT]
"""

from __future__ import annotations

import argparse
import csv
import math
import re
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from generalisation import MARGIN  # noqa: E402

from nct.run.outcome import FINISHED, read_outcome  # noqa: E402
from nct.run.tables import markdown_table, write_csv  # noqa: E402

POOR_DICE = 0.8  # a fit below this Dice is poor whatever FBP scores
HALF_TURN_DEG = 180.0  # a turning object's own frame seen over less than this: its shape is the prior's
CENTRE_MOVES, TURNS = ("orbit", "translation"), ("rotation",)
OTHER = "other"
DEFINITIONS = __doc__.split("\n\n")[2]  # the docstring's list of when each kind is justified


@dataclass(frozen=True)
class Run:
    """One finished or failed run and the truth of its scene: ``motions`` and ``deg_per_rotation``
    per object (the latter empty where the table lacks it), ``rotations`` and gantry ``sense`` (+1
    ccw, -1 cw; NaN and 0 where unknown)."""

    folder: str
    scene: str
    label: str
    status: str
    warnings: tuple[str, ...]
    nct_dice: float
    fbp_dice: float
    nct_mse: float
    fbp_mse: float
    motions: tuple[str, ...]
    deg_per_rotation: tuple[float, ...]
    rotations: float
    sense: int
    noise_i0: str

    @property
    def poor(self) -> bool:
        """The fit is poor: below FBP's Dice - MARGIN, below POOR_DICE, MSE above FBP's, or not scored."""
        scores = (self.nct_dice, self.fbp_dice, self.nct_mse, self.fbp_mse)
        return (not all(math.isfinite(s) for s in scores) or self.nct_dice < self.fbp_dice - MARGIN
                or self.nct_dice < POOR_DICE or self.nct_mse > self.fbp_mse)

    def moves(self, kinds: Sequence[str]) -> bool:
        return any(m in kinds for m in self.motions)

    def turns_unseen(self) -> bool:
        """Some turning object's own frame is seen over less than HALF_TURN_DEG of view angle."""
        return any(self.rotations * abs(360.0 * self.sense - d) < HALF_TURN_DEG
                   for m, d in zip(self.motions, self.deg_per_rotation) if m in TURNS)


@dataclass(frozen=True)
class Kind:
    """A warning kind: ``pattern`` (a regular expression) finds its lines; ``justified`` says, from the
    truth, whether the run deserved it."""

    name: str
    pattern: str
    justified: Callable[[Run], bool]


def never(run: Run) -> bool:
    """The benchmarks' files are right (seconds, exact geometry): a warning that blames them is false."""
    return False


KINDS = (
    Kind("times", r"^times: ", never),
    Kind("motion", r"^motion along the rays is not determined", lambda r: r.moves(CENTRE_MOVES) and r.poor),
    Kind("turn", r"^the moving object turns with the gantry", lambda r: r.turns_unseen() and r.poor),
    Kind("offset", r"^suspect geometry: .*shifted", never),
    Kind("fan", r"^suspect geometry: .*fan beam", never),
    Kind("suspect_fbp", r"^suspect fit: .*above FBP's", lambda r: r.poor),
    Kind("suspect_excess", r"^suspect fit: .*unexplained", lambda r: r.poor),
)
GROUPS = {"geometry (either)": ("offset", "fan"), "suspect fit (either)": ("suspect_fbp", "suspect_excess")}


def classify(line: str) -> str:
    """The kind of one warning line (`KINDS`), `OTHER` when none matches."""
    return next((k.name for k in KINDS if re.search(k.pattern, line)), OTHER)


@dataclass(frozen=True)
class Layout:
    """How a benchmark's folder holds its truth: the ``table``, its NCT and FBP ``dice`` columns and
    the ``run`` folder of a row, under ``runs/``."""

    table: str
    dice: tuple[str, str]
    run: Callable[[dict], str]


LAYOUTS = (Layout("scenes.csv", ("nct_dice", "fbp_dice"), lambda row: f"{row['scene']}/nct"),
           Layout("textured.csv", ("nct_own_dice", "fbp_own_dice"), lambda row: f"{row['scene']}/{row['background']}"))


def number(text: str | None) -> float:
    """A table's cell as a float, NaN when empty or missing."""
    return float(text) if text else math.nan


def read_folder(folder: Path) -> list[Run]:
    """Every run of a generalisation or textured benchmark folder, with its truth."""
    layout = next((lay for lay in LAYOUTS if (folder / lay.table).is_file()), None)
    if layout is None:
        raise SystemExit(f"warnings: error: {folder}: no {' or '.join(lay.table for lay in LAYOUTS)} (the "
                         "generalisation or textured benchmark writes it when its runs are done)")
    with open(folder / layout.table, newline="") as fh:
        rows = list(csv.DictReader(fh))
    runs = []
    for row in rows:
        run_dir = folder / "runs" / layout.run(row)
        outcome = read_outcome(run_dir)
        runs.append(row_run(row, layout.dice, folder.name, run_dir.name, outcome.status, outcome.warnings))
    return runs


def row_run(row: dict, dice: tuple[str, str] = LAYOUTS[0].dice, folder: str = "", label: str = "nct",
            status: str = FINISHED, warnings: tuple[str, ...] = ()) -> Run:
    """A benchmark table's ``row`` (its truth and scores; ``dice``: its NCT and FBP Dice columns) as a `Run`."""
    return Run(folder, row["scene"], label, status, warnings, number(row[dice[0]]), number(row[dice[1]]),
               number(row["nct_mse"]), number(row["fbp_mse"]), tuple(row["motions"].split()),
               tuple(float(d) for d in row.get("deg_per_rotation", "").split()), number(row.get("rotations")),
               {"ccw": 1, "cw": -1}.get(row.get("direction", ""), 0), row.get("noise_i0", ""))


@dataclass(frozen=True)
class Verdict:
    """A run's warned and justified kinds (`KINDS` names, `OTHER` among the warned for unknown lines)."""

    run: Run
    warned: frozenset[str]
    justified: frozenset[str]


def judge(run: Run) -> Verdict:
    """The kinds ``run`` was warned of and those its truth justifies."""
    return Verdict(run, frozenset(classify(w) for w in run.warnings),
                   frozenset(k.name for k in KINDS if k.justified(run)))


@dataclass(frozen=True)
class Tally:
    """Counts over the finished runs for one kind (or group): warned, justified, both."""

    name: str
    runs: int
    warned: int
    justified: int
    hits: int

    @property
    def false_alarms(self) -> int:
        return self.warned - self.hits

    @property
    def misses(self) -> int:
        return self.justified - self.hits

    @property
    def false_alarm_rate(self) -> float:
        return self.false_alarms / self.warned if self.warned else math.nan

    @property
    def miss_rate(self) -> float:
        return self.misses / self.justified if self.justified else math.nan

    def row(self) -> list:
        return [self.name, self.runs, self.warned, self.justified, self.false_alarms, self.false_alarm_rate,
                self.misses, self.miss_rate]


def tally(name: str, verdicts: Sequence[Verdict], warned: Callable[[Verdict], bool],
          justified: Callable[[Verdict], bool]) -> Tally:
    """`Tally` of the finished runs among ``verdicts`` by the ``warned`` and ``justified`` tests."""
    scored = [v for v in verdicts if v.run.status == FINISHED]
    return Tally(name, len(scored), sum(map(warned, scored)), sum(map(justified, scored)),
                 sum(warned(v) and justified(v) for v in scored))


def tallies(verdicts: Sequence[Verdict]) -> list[Tally]:
    """One per kind, one per group of kinds (any of them), one for any warning against a poor fit."""
    sets = [(k.name, {k.name}) for k in KINDS] + [(g, set(names)) for g, names in GROUPS.items()]
    return ([tally(name, verdicts, lambda v, s=s: bool(v.warned & s), lambda v, s=s: bool(v.justified & s))
             for name, s in sets]
            + [tally("any warning / poor fit", verdicts, lambda v: bool(v.warned), lambda v: v.run.poor)])


TALLY_HEADER = ["kind", "runs", "warned", "justified", "false alarms", "false-alarm rate", "misses", "miss rate"]


def outcome(v: Verdict, kind: str) -> str:
    """What one kind did on one run: hit, false alarm, miss or '' (quiet and not deserved)."""
    warned, justified = kind in v.warned, kind in v.justified
    return {(True, True): "hit", (True, False): "false alarm", (False, True): "miss"}.get((warned, justified), "")


def csv_row(v: Verdict) -> dict:
    """warnings.csv's row: the run, its truth, its warned and justified kinds, each kind's `outcome`."""
    r = v.run
    return {"folder": r.folder, "scene": r.scene, "run": r.label, "status": r.status, "motions": " ".join(r.motions),
            "deg_per_rotation": " ".join(f"{d:g}" for d in r.deg_per_rotation), "rotations": r.rotations,
            "noise_i0": r.noise_i0, "nct_dice": r.nct_dice, "fbp_dice": r.fbp_dice, "nct_mse": r.nct_mse,
            "fbp_mse": r.fbp_mse, "poor": r.poor, "warned": " ".join(sorted(v.warned)),
            "justified": " ".join(sorted(v.justified)), **{k.name: outcome(v, k.name) for k in KINDS},
            "other": " / ".join(w for w in r.warnings if classify(w) == OTHER)}


def report(verdicts: Sequence[Verdict], command: str) -> str:
    """The markdown note: command, the rates over every folder (and per folder when several), the runs."""
    folders = list(dict.fromkeys(v.run.folder for v in verdicts))
    failed = [f"{v.run.folder}/{v.run.scene}/{v.run.label} ({v.run.status})" for v in verdicts
              if v.run.status != FINISHED]
    parts = ["# Warnings as a classifier", "", f"Command: `{command}`", "",
             "When a warning is justified, from the truth (benchmarks/warning_rates.py):", "", DEFINITIONS, "",
             f"A run that did not finish warns nothing and is not scored ({len(failed)}"
             + (f": {', '.join(failed)}" if failed else "") + ").", "", f"## All folders ({', '.join(folders)})", "",
             markdown_table(TALLY_HEADER, [t.row() for t in tallies(verdicts)]), ""]
    if len(folders) > 1:
        for folder in folders:
            mine = [v for v in verdicts if v.run.folder == folder]
            parts += [f"## {folder}", "", markdown_table(TALLY_HEADER, [t.row() for t in tallies(mine)]), ""]
    return "\n".join(parts + ["## Runs", "", markdown_table(RUN_HEADER, [run_cells(v) for v in verdicts]), ""])


RUN_HEADER = ["folder", "scene", "run", "status", "motions", "deg/rot", "rot", "I0", "NCT Dice", "FBP Dice",
              "NCT MSE", "FBP MSE", "fit", "warned", "justified"]


def run_cells(v: Verdict) -> list:
    """warnings.md's row for one run (`RUN_HEADER`)."""
    r = v.run
    return [r.folder, r.scene, r.label, r.status, " ".join(r.motions), " ".join(f"{d:g}" for d in r.deg_per_rotation),
            r.rotations, f"{float(r.noise_i0):.2g}" if r.noise_i0 else "none", r.nct_dice, r.fbp_dice, r.nct_mse,
            r.fbp_mse, "poor" if r.poor else "", " ".join(sorted(v.warned)), " ".join(sorted(v.justified))]


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("folders", type=Path, nargs="+", metavar="DIR",
                        help="generalisation or textured benchmark output folders (their --out)")
    stamp = time.strftime("%Y%m%d-%H%M%S")
    parser.add_argument("--out", type=Path, default=Path(f"outputs/benchmarks/warnings-{stamp}"),
                        help="output folder (default outputs/benchmarks/warnings-<date and time>)")
    args = parser.parse_args(argv)
    verdicts = [judge(run) for folder in args.folders for run in read_folder(folder)]
    write_csv([csv_row(v) for v in verdicts], args.out / "warnings.csv")
    command = "python " + " ".join([Path(sys.argv[0]).as_posix(), *(argv if argv is not None else sys.argv[1:])])
    text = report(verdicts, command)
    (args.out / "warnings.md").write_text(text)
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
