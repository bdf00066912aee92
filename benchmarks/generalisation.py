"""Generalisation (issue 9, item 6): nct on sinogram files written by independent code.

Draws ``--scenes`` random scenes from ``--seed`` (benchmarks/scenes.py: 1-3 moving or static
ellipses, apart or nested, in unit field of view, cm or mm, random scanners, Poisson noise or
none), simulates each analytically, writes it as a sinogram file under ``--out/scenes`` and
reconstructs it with ``nct data=file data.path=<file> data.n_objects=K`` (the default method,
nothing tuned per scene; ``--override`` adds the same overrides to every run). One NeuralCT run per
scene scores both methods (its metrics.json holds FBP's summary too); a scene whose NeuralCT run
fails gets an FBP-only run so that FBP is still scored. A failed, diverged, timed-out or NaN
NeuralCT run counts as Dice 0, never dropped.

Acceptance (issue 9): (a) no crash; (b) NCT Dice >= FBP Dice - 0.01 on every scene; (c) NCT Dice
>= 0.90 on >= 90 % of the moving scenes whose smallest semi-axis is >= 4 % of the field of view.

Writes scenes.csv (one row per scene: drawn parameters, categories, both methods' scores),
categories.csv, nct_vs_fbp.png and generalisation.md.

Run: python benchmarks/generalisation.py [--quick] [--scenes N] [--seed S] [--size N] [--jobs 2]
     [--subset | --only SCENE,...] [--override KEY=VALUE ...] [--out DIR] [--resume] [--timeout S]
"""

from __future__ import annotations

import json
import math
import sys
import time
from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from scene_files import write_scene  # noqa: E402
from scenes import Scene, draw_scenes  # noqa: E402

from nct.analysis.benchmarking import (  # noqa: E402
    QUIET,
    Job,
    Record,
    benchmark_parser,
    companion,
    positive_int,
    run_jobs,
)
from nct.run.metrics import dice  # noqa: E402
from nct.run.tables import markdown_table, write_csv  # noqa: E402

MARGIN = 0.01  # (b): NCT may trail FBP by at most this much Dice
TARGET_DICE, TARGET_SHARE, MIN_RADIUS_PCT = 0.90, 0.90, 4.0  # (c)
CATEGORY_KEYS = ("motion", "family", "speed", "size", "noise", "layout", "units")
QUICK_SCENES, QUICK_SIZE, QUICK_FRAMES = 8, 64, 8
FULL_SCENES, FULL_SIZE, FULL_FRAMES = 100, 128, 12
NCT_SEED = 0  # the method's seed, the same for every scene: scenes vary, the method does not
# The fixed subset every change to the method reruns first (--subset; sampler seed 0, 128 px): one- to
# two-rotation scenes of every family, the borderline ones and the failures: static single (031) and
# nested (086); single moving slow (019, 088: small) and fast (002; 050 over 4 rotations); two apart fast
# (033), nested fast (079); three apart fast (084; 067, the closest to FBP).
SUBSET = ("scene002", "scene019", "scene031", "scene033", "scene050", "scene067", "scene079", "scene084",
          "scene086", "scene088")


@dataclass(frozen=True)
class Outcome:
    """One scene's result: its NeuralCT record and FBP's (from the same run, or its own when the
    NeuralCT run failed)."""

    scene: Scene
    nct: Record
    fbp: Record

    @property
    def nct_dice(self) -> float:
        """NeuralCT's median Dice, a failure scored 0."""
        return 0.0 if self.nct.failed else self.nct.dice

    @property
    def fbp_dice(self) -> float:
        return 0.0 if self.fbp.failed else self.fbp.dice

    @property
    def below_fbp(self) -> bool:
        """Criterion (b) broken: NeuralCT more than ``MARGIN`` below FBP."""
        return self.nct_dice < self.fbp_dice - MARGIN

    @property
    def in_target(self) -> bool:
        """Counted by criterion (c): moving, every object at least ``MIN_RADIUS_PCT`` % of the FOV."""
        return self.scene.moving and self.scene.smallest_radius_pct() >= MIN_RADIUS_PCT

    def nested_dice(self) -> dict[str, float]:
        """Median Dice over frames of each nested object at its own level (``Scene.own_levels``), for
        NeuralCT and FBP, the worst nested object of the scene; NaN without nesting or frames.
        The threshold applies to the whole frame, so a brighter object elsewhere counts too."""
        levels = self.scene.own_levels()
        path = self.nct.job.run_dir / "reconstruction.npz"
        if not levels or self.nct.failed or not path.is_file():
            return {"nct_nested_dice": math.nan, "fbp_nested_dice": math.nan}
        scene_file = Path(dict(o.split("=", 1) for o in self.nct.job.overrides if "=" in o)["data.path"])
        with np.load(path) as rec, np.load(scene_file) as data:
            truth = data["truth"]
            return {f"{m}_nested_dice": min(median(list(dice(rec[m] >= t, truth >= t))) for t in levels.values())
                    for m in ("nct", "fbp")}

    @cached_property
    def chosen(self) -> dict:
        """The candidate the run's tournament chose, its row of the table (metrics.json ``selection``: winner,
        n_objects, background; empty for a failed run), read once."""
        path = self.nct.job.run_dir / "metrics.json"
        if self.nct.failed or not path.is_file():
            return {}
        selection = json.loads(path.read_text()).get("selection", {})
        return next((row for row in selection.get("table", []) if row["candidate"] == selection.get("winner")), {})

    @property
    def winner(self) -> str:
        return self.chosen.get("candidate", "")

    @property
    def model_right(self) -> bool | None:
        """Whether the run fitted the scene's own model: one object per ellipse, no background (None: failed)."""
        if not self.chosen:
            return None
        return self.chosen["n_objects"] == len(self.scene.objects) and self.chosen["background"] == "none"

    @property
    def model_equivalent(self) -> bool | None:
        """Whether the run fitted the scene's own model or one that draws the same objects: its moving ellipses as
        the objects over a background image that holds its still ones (None: failed)."""
        if not self.chosen:
            return None
        moving = sum(o.motion.kind != "static" for o in self.scene.objects)
        held = (self.chosen["background"] == "image" and self.chosen["n_objects"] == moving
                and 0 < moving < len(self.scene.objects))
        return bool(self.model_right or held)

    def row(self) -> dict:
        """The scene's parameters, categories and both methods' scores, flat."""
        return {**self.scene.parameters(), **self.scene.categories(), **self.nested_dice(),
                "nct_status": self.nct.status, "winner": self.winner, "chosen_k": self.chosen.get("n_objects"),
                "chosen_background": self.chosen.get("background"), "model_right": self.model_right,
                "model_equivalent": self.model_equivalent,
                "nct_dice": self.nct.dice, "nct_mse": self.nct.mse,
                "fbp_status": self.fbp.status, "fbp_dice": self.fbp.dice, "fbp_mse": self.fbp.mse,
                "nct_minus_fbp": self.nct_dice - self.fbp_dice, "below_fbp": self.below_fbp,
                "wall_time_s": self.nct.wall_time_s, "run_time_s": self.nct.run_time_s,
                "fbp_from": "nct run" if self.fbp.job.run_dir == self.nct.job.run_dir else "own run",
                "error": first_line(self.nct.error), "run_dir": str(self.nct.job.run_dir)}


def first_line(text: str | None) -> str:
    """The first line of an error message ('' for none)."""
    return (text or "").strip().splitlines()[0] if (text or "").strip() else ""


def scene_overrides(scene: Scene, path: Path, extra: Sequence[str], n_objects: int | None = None,
                    told: bool = True) -> tuple[str, ...]:
    """The ``nct`` overrides that reconstruct ``scene``'s file: ``told``, with K = ``n_objects`` (None: its number
    of objects) and, unless ``extra`` names one, no background (the model a user would have to know); else
    with nothing about the scene, as a user would run the file."""
    if not told:
        return ("data=file", f"data.path={path.resolve()}", *QUIET, *extra)
    k = len(scene.objects) if n_objects is None else n_objects
    background = () if any(o.startswith("background=") for o in extra) else ("background=none",)
    return ("data=file", f"data.path={path.resolve()}", f"data.n_objects={k}", *background, *QUIET, *extra)


def plan(out: Path, scenes: Sequence[Scene], files: Sequence[Path], extra: Sequence[str], told: bool) -> list[Job]:
    """One NeuralCT job per scene, in ``out/runs/<scene>/nct``."""
    return [Job({"scene": s.name}, "nct", NCT_SEED, scene_overrides(s, f, extra, told=told),
                out / "runs" / s.name / "nct") for s, f in zip(scenes, files)]


def fbp_fallbacks(records: Sequence[Record]) -> list[Job]:
    """FBP-only jobs for the scenes whose NeuralCT run left no FBP score (the run failed)."""
    return [Job(r.job.labels, "fbp", r.job.seed, r.job.overrides, r.job.run_dir.parent / "fbp")
            for r in records if companion(r, "fbp").failed]


def outcomes(scenes: Sequence[Scene], nct: Sequence[Record], fallback: Sequence[Record]) -> list[Outcome]:
    """Pair every scene with its NeuralCT record and its FBP record (own run if there is one)."""
    own = {r.job.labels["scene"]: r for r in fallback}
    return [Outcome(s, r, own.get(s.name) or companion(r, "fbp")) for s, r in zip(scenes, nct)]


def median(values: Sequence[float]) -> float:
    finite = [v for v in values if math.isfinite(v)]
    return float(np.median(finite)) if finite else math.nan


def category_rows(results: Sequence[Outcome]) -> list[dict]:
    """Per category value (and 'all'): scenes, median Dice of both methods (NeuralCT failures as 0),
    median MSE (successful runs), crashes, scenes below FBP - margin, median wall time, and how often
    each candidate won the run's tournament (``winner``)."""
    groups = [("all", "all", list(results))]
    for key in CATEGORY_KEYS:
        values = dict.fromkeys(o.scene.categories()[key] for o in results)
        groups += [(key, v, [o for o in results if o.scene.categories()[key] == v]) for v in values]
    return [{"category": key, "value": value, "scenes": len(mine),
             "nct_dice": median([o.nct_dice for o in mine]), "fbp_dice": median([o.fbp_dice for o in mine]),
             "nct_mse": median([o.nct.mse for o in mine if not o.nct.failed]),
             "fbp_mse": median([o.fbp.mse for o in mine if not o.fbp.failed]),
             "nct_failed": sum(o.nct.failed for o in mine), "fbp_failed": sum(o.fbp.failed for o in mine),
             "below_fbp": sum(o.below_fbp for o in mine), "wall_time_s": median([o.nct.wall_time_s for o in mine]),
             "winners": " ".join(f"{name}:{n}" for name, n in Counter(o.winner or "none" for o in mine).most_common())}
            for key, value, mine in groups]


@dataclass(frozen=True)
class Acceptance:
    """The issue's three checks: crashes, scenes where NCT < FBP - margin, and the share of target
    scenes (moving, radius >= 4 %) with NCT Dice >= 0.90 (NaN when there are none)."""

    crashes: list[Outcome]
    below_fbp: list[Outcome]
    target_scenes: int
    target_good: int

    @property
    def share(self) -> float:
        return self.target_good / self.target_scenes if self.target_scenes else math.nan

    def lines(self) -> list[str]:
        """One line per check, with PASS / FAIL."""
        def verdict(ok: bool) -> str:
            return "PASS" if ok else "FAIL"

        crashed = ", ".join(f"{o.scene.name} ({o.nct.status}: {first_line(o.nct.error)})" for o in self.crashes)
        below = ", ".join(f"{o.scene.name} ({o.nct_dice:.3f} vs {o.fbp_dice:.3f})" for o in self.below_fbp)
        return [f"(a) no crash: {verdict(not self.crashes)}, {len(self.crashes)} crashed"
                + (f": {crashed}" if crashed else ""),
                f"(b) NCT >= FBP - {MARGIN} Dice on every scene: {verdict(not self.below_fbp)}, "
                f"{len(self.below_fbp)} below" + (f": {below}" if below else ""),
                f"(c) NCT >= {TARGET_DICE} on >= {TARGET_SHARE:.0%} of the moving scenes with radius >= "
                f"{MIN_RADIUS_PCT:g} %: " + (f"{verdict(self.share >= TARGET_SHARE)}, {self.target_good}/"
                                             f"{self.target_scenes} ({self.share:.0%})" if self.target_scenes
                                             else "no such scene")]


def acceptance(results: Sequence[Outcome]) -> Acceptance:
    """Evaluate the issue's checks on ``results``."""
    target = [o for o in results if o.in_target]
    return Acceptance(crashes=[o for o in results if o.nct.failed or o.fbp.failed],
                      below_fbp=[o for o in results if o.below_fbp], target_scenes=len(target),
                      target_good=sum(o.nct_dice >= TARGET_DICE for o in target))


def colour_class(scene: Scene) -> str:
    """The chart's colour: static, moving (< 150 deg/rot) or fast."""
    return {"none": "static", "slow": "moving", "fast": "fast (>= 150 deg/rot)"}[scene.categories()["speed"]]


def plot(results: Sequence[Outcome], path: Path) -> Path:
    """NCT Dice against FBP Dice per scene: colour by motion (static / moving / fast), hollow for small
    objects, crosses for failed NeuralCT runs (at 0); the diagonal and y = x - margin."""
    fig, ax = plt.subplots(figsize=(6, 6))
    colours = {"static": "C0", "moving": "C1", "fast (>= 150 deg/rot)": "C3"}
    for label, colour in colours.items():
        mine = [o for o in results if colour_class(o.scene) == label]
        for small in (False, True):
            pts = [o for o in mine if (o.scene.categories()["size"] == "small") == small and not o.nct.failed]
            if not pts:
                continue
            name = f"{label}{', small' if small else ''} ({len(pts)})"
            ax.scatter([o.fbp_dice for o in pts], [o.nct_dice for o in pts], s=28, edgecolors=colour,
                       facecolors="none" if small else colour, label=name)
        failed = [o for o in mine if o.nct.failed]
        if failed:
            ax.scatter([o.fbp_dice for o in failed], [0.0] * len(failed), marker="x", color=colour,
                       label=f"{label}: NCT failed ({len(failed)})")
    lo = min([0.5] + [min(o.fbp_dice, o.nct_dice) for o in results])
    ax.plot([lo, 1], [lo, 1], color="grey", lw=1, label="y = x")
    ax.plot([lo, 1], [lo - MARGIN, 1 - MARGIN], color="grey", lw=1, ls="--", label=f"y = x - {MARGIN}")
    ax.set(xlabel="FBP median Dice", ylabel="NCT median Dice", xlim=(lo - 0.02, 1.01), ylim=(lo - 0.02, 1.01),
           title="NCT against FBP per scene")
    ax.legend(fontsize=7, loc="upper left")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def report(results: Sequence[Outcome], categories: Sequence[dict], checks: Acceptance, command: str,
           elapsed_s: float) -> str:
    """The markdown note: command, checks, the category table, then one row per scene."""
    per_category = markdown_table(
        ["category", "value", "scenes", "NCT Dice", "FBP Dice", "NCT MSE", "FBP MSE", "NCT failed", "FBP failed",
         "NCT < FBP - 0.01", "wall s", "chosen (scenes)"],
        [[c["category"], c["value"], c["scenes"], c["nct_dice"], c["fbp_dice"], c["nct_mse"], c["fbp_mse"],
          c["nct_failed"], c["fbp_failed"], c["below_fbp"], c["wall_time_s"], c["winners"]] for c in categories])
    per_scene = markdown_table(
        ["scene", "units", "K", "layout", "motions", "deg/rot", "min radius %", "views/rot", "rot", "I0",
         "FBP Dice", "NCT Dice", "FBP MSE", "NCT MSE", "NCT status", "chosen", "wall s"],
        [[o.scene.name, o.scene.units, len(o.scene.objects), o.scene.layout,
          " ".join(m.motion.kind for m in o.scene.objects),
          o.scene.max_deg_per_rotation, o.scene.smallest_radius_pct(), o.scene.acquisition.views_per_rotation,
          o.scene.acquisition.rotations, f"{o.scene.noise_i0:.2g}" if o.scene.noise_i0 else "none", o.fbp_dice,
          o.nct_dice, o.fbp.mse, o.nct.mse,
          o.nct.status if not o.nct.failed else f"{o.nct.status}: {first_line(o.nct.error)}", o.winner,
          o.nct.wall_time_s] for o in results])
    nested = [(o, o.nested_dice()) for o in results if o.scene.own_levels()]
    judged = [o for o in results if o.model_right is not None]
    wrong = markdown_table(["scene", "motions", "chosen K", "chosen background", "still ones in the image",
                            "NCT Dice", "FBP Dice", "NCT MSE", "FBP MSE"],
                           [[o.scene.name, " ".join(m.motion.kind for m in o.scene.objects), o.chosen["n_objects"],
                             o.chosen["background"], "yes" if o.model_equivalent else "no", o.nct_dice, o.fbp_dice,
                             o.nct.mse, o.fbp.mse] for o in judged if not o.model_right])
    models = (f"The run fitted the scene's own model (one object per ellipse, no background) on "
              f"{sum(o.model_right for o in judged)} of {len(judged)} finished runs, and its moving ellipses over "
              f"an image holding the still ones on {sum(o.model_equivalent and not o.model_right for o in judged)} "
              "more; the others:")
    per_nested = markdown_table(
        ["scene", "motions", "intensities", "FBP Dice at own level", "NCT Dice at own level"],
        [[o.scene.name, " ".join(m.motion.kind for m in o.scene.objects),
          " ".join(f"{m.intensity:.2f}" for m in o.scene.objects), d["fbp_nested_dice"], d["nct_nested_dice"]]
         for o, d in nested])
    return "\n".join(["# Generalisation", "", f"Command: `{command}` (this call: {elapsed_s / 60:.1f} min).", "",
                      "Scenes drawn by `benchmarks/scenes.py` and simulated by `benchmarks/scene_files.py` "
                      "(independent of nct), reconstructed by "
                      "`nct data=file` with the default method; a failed NeuralCT run counts as Dice 0. Dice and "
                      "MSE: each run's median over frames; per category: the median over scenes.", "",
                      "## Acceptance", "", *[f"- {line}" for line in checks.lines()], "",
                      "## Per category", "", per_category, "", "![NCT against FBP](nct_vs_fbp.png)", "",
                      "## The scene model each run chose", "", models, "", wrong, "",
                      "## Nested objects at their own level (issue 9, item 5)", "",
                      "Dice of each nested object at its containers' level plus half its own (the worst nested "
                      "object of the scene; the threshold applies to the whole frame).", "", per_nested, "",
                      "## Per scene", "", per_scene, ""])


def parse(argv: Sequence[str] | None = None):
    """Command-line options: the harness's shared ones plus the scene sampler's and ``--override``."""
    parser = benchmark_parser("generalisation", __doc__.split("\n\n")[0],
                              f"{QUICK_SCENES} scenes at {QUICK_SIZE} pixels, {QUICK_FRAMES} frames per rotation", None)
    parser.add_argument("--scenes", type=positive_int, help=f"scenes to draw (default {FULL_SCENES}; "
                        f"--quick {QUICK_SCENES}); the first N of the seed's sequence")
    parser.add_argument("--seed", type=int, default=0, help="seed of the scene sampler (default 0)")
    parser.add_argument("--size", type=positive_int, help=f"truth grid and detector bins (default {FULL_SIZE}; "
                        f"--quick {QUICK_SIZE})")
    parser.add_argument("--frames", type=positive_int, help=f"truth frames per rotation (default {FULL_FRAMES}; "
                        f"--quick {QUICK_FRAMES})")
    parser.add_argument("--subset", action="store_const", const=list(SUBSET), dest="only",
                        help="the fixed subset every change to the method reruns first (sampler seed 0): "
                        + ",".join(SUBSET))
    parser.add_argument("--only", type=lambda text: text.split(","), metavar="SCENE,...",
                        help="run and report only these of the drawn scenes (e.g. scene006,scene038)")
    parser.add_argument("--override", action="append", default=[], metavar="KEY=VALUE",
                        help="an nct override added to every run (repeatable), e.g. a step count")
    parser.add_argument("--told", action="store_true", help="pass each scene's model (data.n_objects = its objects, "
                        "background=none) as a user who knew it would; default: nothing about the scene, as a user "
                        "would run a file")
    args = parser.parse_args(argv)
    args.scenes = args.scenes or (QUICK_SCENES if args.quick else FULL_SCENES)
    args.size = args.size or (QUICK_SIZE if args.quick else FULL_SIZE)
    args.frames = args.frames or (QUICK_FRAMES if args.quick else FULL_FRAMES)
    return args


def main(argv: Sequence[str] | None = None) -> int:
    args = parse(argv)
    start = time.perf_counter()
    scenes = draw_scenes(args.seed, args.scenes)
    if args.only:
        unknown = sorted(set(args.only) - {s.name for s in scenes})
        if unknown:
            raise SystemExit(f"--only: not among the {len(scenes)} scenes drawn: {', '.join(unknown)}")
        scenes = [s for s in scenes if s.name in args.only]
    files = [write_scene(s, args.out / "scenes" / f"{s.name}.npz", args.size, args.frames, args.seed) for s in scenes]
    print(f"{len(scenes)} scenes written to {args.out / 'scenes'}")
    nct = run_jobs(plan(args.out, scenes, files, args.override, args.told), args.jobs, args.resume, args.timeout, args.threads)
    fallback = run_jobs(fbp_fallbacks(nct), args.jobs, args.resume, args.timeout, args.threads)
    results = outcomes(scenes, nct, fallback)
    categories = category_rows(results)
    checks = acceptance(results)
    write_csv([o.row() for o in results], args.out / "scenes.csv")
    write_csv(categories, args.out / "categories.csv")
    plot(results, args.out / "nct_vs_fbp.png")
    command = "python " + " ".join([Path(sys.argv[0]).as_posix(), *(argv if argv is not None else sys.argv[1:])])
    (args.out / "generalisation.md").write_text(report(results, categories, checks, command,
                                                       time.perf_counter() - start))
    print("\n".join(checks.lines()))
    print(f"wrote {args.out / 'generalisation.md'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
