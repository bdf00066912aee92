"""Moving objects in textured static surroundings (issue 29, item 4): random scenes from files, with and without a background image.

Draws ``--scenes`` scenes of each family (benchmarks/scenes.py `draw_textured_scene`, independent of
nct: 1-2 moving objects brighter than what surrounds them inside a static body that is ``gradient``
(intensity varying linearly across it), ``structures`` (small static ellipses brighter and darker
than it) or ``holes`` (static low-intensity inclusions, lungs)), simulates each analytically
(scene_files.py; ``truth_level`` half the body's intensity) and reconstructs it with ``nct data=file``
once per ``--backgrounds``: ``image`` (``background=image`` with K = the moving objects), ``none``
(``background=none`` with K = every object of the scene: body, inclusions and moving objects) and
``auto`` (nothing about the scene passed: the run chooses K and the background; the K column then
names the model it chose).

Scores per scene and background, each the median over frames: whole-image MSE of FBP and NCT
(metrics.json ``fbp``/``nct`` -> ``median_mse``; FBP's is the same in both runs), NCT's MSE over
FBP's, and each moving object's Dice at its own level (its container's intensity plus half its own:
``surround.moving_levels``; every static pixel lies at least ``scenes.LEVEL_MARGIN`` below it), the
whole frame thresholded. A failed run scores NaN MSE and Dice 0. Writes textured.csv (one row per
run), families.csv (medians per family and background) and textured.md.

Run: python benchmarks/textured.py [--quick] [--scenes N] [--seed S] [--size N] [--frames F]
     [--families gradient structures holes] [--backgrounds image none auto] [--only NAME,...]
     [--override KEY=VALUE ...] [--out DIR] [--jobs 2] [--threads T] [--resume] [--timeout S]
"""

from __future__ import annotations

import json
import math
import sys
import time
from collections.abc import Sequence
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from generalisation import NCT_SEED, first_line, median, scene_overrides  # noqa: E402
from scene_files import write_scene  # noqa: E402
from scenes import FAMILIES, Scene, draw_textured_scene  # noqa: E402
from surround import moving_levels  # noqa: E402

from nct.analysis.benchmarking import (  # noqa: E402
    Job,
    Record,
    benchmark_parser,
    companion,
    positive_int,
    run_jobs,
)
from nct.run.metrics import dice  # noqa: E402
from nct.run.tables import markdown_table, write_csv  # noqa: E402

BACKGROUNDS = ("image", "none", "auto")  # told K over an image; told K on none; nothing passed (the run chooses)
QUICK_SCENES, QUICK_SIZE, QUICK_FRAMES = 1, 64, 8
FULL_SCENES, FULL_SIZE, FULL_FRAMES = 3, 128, 12


def scene_name(scene: Scene) -> str:
    """``<family><index>``, e.g. holes002 (``Scene.layout`` holds the family)."""
    return f"{scene.layout}{scene.index:03d}"


def n_objects(scene: Scene, background: str) -> int | None:
    """K: the moving objects over a background image; every object without one; None where the run chooses
    (``auto``: nothing about the scene passed)."""
    return {"image": len(moving_levels(scene)), "none": len(scene.objects)}.get(background)


def overrides(scene: Scene, path: Path, background: str, extra: Sequence[str]) -> tuple[str, ...]:
    """A run's overrides: told K and background, or nothing about the scene (``auto``)."""
    if background == "auto":
        return scene_overrides(scene, path, extra, told=False)
    return scene_overrides(scene, path, [f"background={background}", *extra], n_objects(scene, background))


def plan(out: Path, scenes: Sequence[Scene], files: Sequence[Path], backgrounds: Sequence[str],
         extra: Sequence[str]) -> list[Job]:
    """One NeuralCT job per scene and background, in ``out/runs/<scene>/<background>``."""
    return [Job({"family": s.layout, "scene": scene_name(s), "background": b}, "nct", NCT_SEED,
                overrides(s, f, b, extra), out / "runs" / scene_name(s) / b)
            for s, f in zip(scenes, files) for b in backgrounds]


def own_dice(rec: np.ndarray, truth: np.ndarray, levels: Sequence[float]) -> list[float]:
    """Median over frames of Dice at each level (the whole frame thresholded), one per level."""
    return [float(np.median(dice(rec >= t, truth >= t))) for t in levels]


def row(scene: Scene, nct: Record, path: Path) -> dict:
    """One run's figures: both methods' whole-image MSE, the ratio, each moving object's own-level Dice
    (space-separated, in object order) and the worst of them (0 without a reconstruction)."""
    fbp = companion(nct, "fbp")
    levels = list(moving_levels(scene).values())
    rec_path = nct.job.run_dir / "reconstruction.npz"
    own = {"nct": [math.nan] * len(levels), "fbp": [math.nan] * len(levels)}
    if rec_path.is_file():
        with np.load(rec_path) as rec, np.load(path) as data:
            own = {m: own_dice(rec[m], data["truth"], levels) for m in ("nct", "fbp")}
    if nct.failed:
        own["nct"] = [0.0] * len(levels)
    nct_mse = math.nan if nct.failed else nct.mse
    fbp_mse = math.nan if fbp.failed else fbp.mse
    return {**nct.job.labels, "K": n_objects(scene, nct.job.labels["background"]), "chosen": chosen(nct),
            "moving": len(levels),
            "objects": len(scene.objects), "motions": " ".join(o.motion.kind for o in scene.objects
                                                               if o.motion.kind != "static"),
            "views": scene.acquisition.n_views, "noise_i0": scene.noise_i0 or "",
            "fbp_mse": fbp_mse, "nct_mse": nct_mse, "mse_ratio": nct_mse / fbp_mse,
            "fbp_own_dice": min(own["fbp"]), "nct_own_dice": min(own["nct"]),
            "fbp_own_dices": " ".join(f"{d:.3f}" for d in own["fbp"]),
            "nct_own_dices": " ".join(f"{d:.3f}" for d in own["nct"]),
            "nct_status": nct.status, "error": first_line(nct.error), "wall_time_s": nct.wall_time_s,
            "run_dir": str(nct.job.run_dir)}


def chosen(nct: Record) -> str:
    """The scene model the run fitted, as ``<K> <background>`` (its table's winner; '' for a failed run)."""
    path = nct.job.run_dir / "metrics.json"
    if nct.failed or not path.is_file():
        return ""
    selection = json.loads(path.read_text())["selection"]
    win = next(r for r in selection["table"] if r["candidate"] == selection["winner"])
    return f"{win['n_objects']} {win['background']}"


def family_rows(rows: Sequence[dict]) -> list[dict]:
    """Per family and background (and 'all'): runs, failures, medians over scenes of both MSEs, the
    ratio, both worst own-level Dice and the wall time."""
    keys = list(dict.fromkeys((r["family"], r["background"]) for r in rows))
    keys += [("all", b) for b in dict.fromkeys(r["background"] for r in rows)]
    out = []
    for family, background in keys:
        mine = [r for r in rows if family in ("all", r["family"]) and r["background"] == background]
        out.append({"family": family, "background": background, "runs": len(mine),
                    "nct_failed": sum(r["nct_status"] != "ok" for r in mine),
                    **{k: median([r[k] for r in mine]) for k in ("fbp_mse", "nct_mse", "mse_ratio", "fbp_own_dice",
                                                                 "nct_own_dice", "wall_time_s")}})
    return out


def report(rows: Sequence[dict], families: Sequence[dict], command: str, size: int, elapsed_s: float) -> str:
    """The markdown note: command, the per-family medians, then one row per run."""
    per_family = markdown_table(
        ["family", "background", "runs", "NCT failed", "FBP MSE", "NCT MSE", "NCT/FBP MSE", "FBP own Dice",
         "NCT own Dice", "wall s"],
        [[f["family"], f["background"], f["runs"], f["nct_failed"], f["fbp_mse"], f["nct_mse"], f["mse_ratio"],
          f["fbp_own_dice"], f["nct_own_dice"], f["wall_time_s"]] for f in families])
    per_run = markdown_table(
        ["scene", "background", "K", "chosen", "motions", "views", "FBP MSE", "NCT MSE", "NCT/FBP MSE", "FBP own Dice",
         "NCT own Dice", "status", "wall s"],
        [[r["scene"], r["background"], r["K"], r["chosen"], r["motions"], r["views"], r["fbp_mse"], r["nct_mse"],
          r["mse_ratio"],
          r["fbp_own_dices"], r["nct_own_dices"],
          r["nct_status"] if r["nct_status"] == "ok" else f"{r['nct_status']}: {r['error']}", r["wall_time_s"]]
         for r in rows])
    return "\n".join([f"# Moving objects in textured static surroundings ({size} px)", "",
                      f"Command: `{command}` (this call: {elapsed_s / 60:.1f} min).", "",
                      "Scenes drawn by `benchmarks/scenes.py` (`draw_textured_scene`) and simulated by "
                      "`scene_files.py`, independent of nct. `image`: `background=image`, K = the moving objects; "
                      "`none`: no background, K = every object. MSE: whole image, median over frames; own Dice: "
                      "each moving object at its container's level plus half its own (per family: the worst "
                      "object of each scene, median over scenes; a failed run counts 0).", "",
                      "## Per family", "", per_family, "", "## Per run", "", per_run, ""])


def parse(argv: Sequence[str] | None = None):
    parser = benchmark_parser("textured", __doc__.split("\n\n")[0],
                              f"{QUICK_SCENES} scene per family at {QUICK_SIZE} pixels, {QUICK_FRAMES} frames "
                              "per rotation", None)
    parser.add_argument("--scenes", type=positive_int, help=f"scenes per family (default {FULL_SCENES}; --quick "
                        f"{QUICK_SCENES}); the first N of the seed's sequence")
    parser.add_argument("--seed", type=int, default=0, help="seed of the scene sampler (default 0)")
    parser.add_argument("--size", type=positive_int, help=f"truth grid and detector bins (default {FULL_SIZE}; "
                        f"--quick {QUICK_SIZE})")
    parser.add_argument("--frames", type=positive_int, help=f"truth frames per rotation (default {FULL_FRAMES}; "
                        f"--quick {QUICK_FRAMES})")
    parser.add_argument("--families", nargs="+", default=list(FAMILIES), choices=FAMILIES)
    parser.add_argument("--backgrounds", nargs="+", default=["image", "none"], choices=BACKGROUNDS,
                        help="image: told K over a background; none: told K, every object; auto: nothing about "
                        "the scene passed, as a user runs a file (default: image none)")
    parser.add_argument("--only", type=lambda text: text.split(","), metavar="NAME,...",
                        help="run and report only these of the drawn scenes (e.g. holes001,gradient000)")
    parser.add_argument("--override", action="append", default=[], metavar="KEY=VALUE",
                        help="an nct override added to every run (repeatable)")
    args = parser.parse_args(argv)
    args.scenes = args.scenes or (QUICK_SCENES if args.quick else FULL_SCENES)
    args.size = args.size or (QUICK_SIZE if args.quick else FULL_SIZE)
    args.frames = args.frames or (QUICK_FRAMES if args.quick else FULL_FRAMES)
    return args


def main(argv: Sequence[str] | None = None) -> int:
    args = parse(argv)
    start = time.perf_counter()
    scenes = [draw_textured_scene(args.seed, f, i) for f in args.families for i in range(args.scenes)]
    if args.only:
        unknown = sorted(set(args.only) - {scene_name(s) for s in scenes})
        if unknown:
            raise SystemExit(f"--only: not among the {len(scenes)} scenes drawn: {', '.join(unknown)}")
        scenes = [s for s in scenes if scene_name(s) in args.only]
    files = [write_scene(s, args.out / "scenes" / f"{scene_name(s)}.npz", args.size, args.frames, args.seed,
                         level=0.5 * s.objects[0].intensity) for s in scenes]
    print(f"{len(scenes)} scenes written to {args.out / 'scenes'}")
    jobs = plan(args.out, scenes, files, args.backgrounds, args.override)
    records = run_jobs(jobs, args.jobs, args.resume, args.timeout, args.threads)
    by_name = {scene_name(s): (s, f) for s, f in zip(scenes, files)}
    rows = [row(by_name[r.job.labels["scene"]][0], r, by_name[r.job.labels["scene"]][1]) for r in records]
    families = family_rows(rows)
    write_csv(rows, args.out / "textured.csv")
    write_csv(families, args.out / "families.csv")
    command = "python " + " ".join([Path(sys.argv[0]).as_posix(), *(argv if argv is not None else sys.argv[1:])])
    text = report(rows, families, command, args.size, time.perf_counter() - start)
    (args.out / "textured.md").write_text(text)
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
