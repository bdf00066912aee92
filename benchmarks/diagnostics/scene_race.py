"""How far apart the held-out views hold the scene models a run compares (objects, background), each fitted to
the end: per scene, told runs of its own model, one object more, and the other background (an image under its
moving parts; or, for a scene with one, every object on none, at most ``MAX_OBJECTS``), each as a told run fits it
(its starts raced), scored truth-free (the winner's held-out misfit at each check and at the end) and against the
truth (Dice). What ``motion.scene_tolerance`` must separate.

A run's candidates draw from streams keyed by their rung and start, not their scene model, so each told run
here fits as that scene model's candidates do in a run that chooses (select/candidates.py).

    python benchmarks/diagnostics/scene_race.py --out outputs/scene_race --jobs 1
    python benchmarks/diagnostics/scene_race.py --out outputs/scene_race --only scene002,heart_cine --resume
"""

from __future__ import annotations

import argparse
import json
import math
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import generalisation as G  # noqa: E402
import scenes as S  # noqa: E402
import textured as T  # noqa: E402
from scene_files import write_scene  # noqa: E402
from surround import moving_levels, surround_scenes  # noqa: E402

from nct.analysis.benchmarking import Job, run_jobs  # noqa: E402
from nct.run.tables import markdown_table, write_csv  # noqa: E402
from nct.select.scene import MAX_OBJECTS  # noqa: E402

TEXTURED = ("holes000", "holes001", "gradient001", "structures001")
EXPERIMENTS = {"heart_cine": (1, "none", 1), "letters": (1, "none", 1), "static": (2, "none", 1),
               "nodule": (3, "none", 2), "thorax": (2, "image", 4)}  # own K, background, the other's K
QUIET = ("logger=none", "export.gif=false", "export.png=false", "export.tiff=false", "threads=1")


@dataclass(frozen=True)
class SceneFile:
    """A scene's file and the scene models raced on it, its own first."""

    name: str
    path: Path
    models: tuple[tuple[int, str], ...]


def raced(k: int, background: str, other_k: int) -> tuple[tuple[int, str], ...]:
    """Its own model, one object more, the other background with ``other_k`` objects."""
    other = "image" if background == "none" else "none"
    return (k, background), (k + 1, background), (max(1, min(other_k, MAX_OBJECTS)), other)


def scene_files(out: Path, size: int) -> list[SceneFile]:
    """The generalisation subset, four textured scenes, the vessel in a body and five experiments, as files."""
    found = []
    drawn = {s.name: s for s in S.draw_scenes(0, 100)}
    for name in G.SUBSET:
        s = drawn[name]
        movers = sum(o.motion.kind != "static" for o in s.objects)
        found.append(SceneFile(name, write_scene(s, out / "scenes" / f"{name}.npz", size, 12, 0),
                               raced(len(s.objects), "none", movers)))
    textured = {T.scene_name(s): s for s in S.draw_textured_scenes(0, 3)}
    for name in TEXTURED:
        s = textured[name]
        path = write_scene(s, out / "scenes" / f"{name}.npz", size, 12, 0, level=0.5 * s.objects[0].intensity)
        found.append(SceneFile(name, path, raced(len(moving_levels(s)), "image", len(s.objects))))
    vessel = surround_scenes(720)[0]
    found.append(SceneFile("vessel", write_scene(vessel, out / "scenes" / "vessel.npz", size, 12, 0),
                           raced(1, "image", len(vessel.objects))))
    for name, (k, background, other) in EXPERIMENTS.items():
        run = out / "experiments" / name
        if not (run / "sinogram.npz").is_file():
            subprocess.run([sys.executable, "-m", "nct.cli.main", f"experiment={name}", "method=fbp", *QUIET,
                            f"hydra.run.dir={run}"], check=True, capture_output=True)
        found.append(SceneFile(name, run / "sinogram.npz", raced(k, background, other)))
    return found


def jobs(out: Path, scenes: list[SceneFile]) -> list[Job]:
    """One told run per scene and model, every fit to the end."""
    return [Job({"scene": s.name, "k": k, "background": b}, "nct", 0,
                ("data=file", f"data.path={s.path.resolve()}", f"data.n_objects={k}", f"background={b}",
                 *QUIET), out / "runs" / s.name / f"k{k}_{b}")
            for s in scenes for k, b in s.models]


def row(job: Job) -> dict:
    """A run's final held-out misfit, its misfit at steps 300 and 500, its Dice, time and status."""
    path = job.run_dir / "metrics.json"
    if not path.is_file():
        return {**job.labels, "status": "failed"}
    m = json.loads(path.read_text())
    winner = m["selection"]["winner"]
    history = dict((int(s), v) for s, v in m["stages"].get(f"{winner}_fit", {}).get("heldout_history", []))
    return {**job.labels, "status": "ok", "misfit": m["heldout_loss"], "at300": history.get(300, math.nan),
            "at500": history.get(500, math.nan), "dice": m.get("nct", {}).get("median_dice", math.nan),
            "fbp_dice": m.get("fbp", {}).get("median_dice", math.nan), "run_s": m["wall_time_s"]}


def report(rows: list[dict], scenes: list[SceneFile]) -> str:
    """Per scene: each model's misfit over its own model's (final, at 300 and 500 steps) and its Dice."""
    table = []
    for s in scenes:
        mine = [r for r in rows if r["scene"] == s.name and r["status"] == "ok"]
        own = next((r for r in mine if (r["k"], r["background"]) == s.models[0]), None)
        for r in mine:
            ratio = {k: r[k] / own[k] if own and own[k] else math.nan for k in ("misfit", "at300", "at500")}
            table.append([s.name, f"k{r['k']}_{r['background']}" + (" (own)" if r is own else ""), r["misfit"],
                          ratio["misfit"], ratio["at300"], ratio["at500"], r["dice"], r["fbp_dice"], r["run_s"]])
    return "\n".join(["# Scene models raced to the end", "", markdown_table(
        ["scene", "model", "held-out misfit", "/ own", "/ own at 300", "/ own at 500", "Dice", "FBP Dice", "run s"],
        table), ""])


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, required=True)
    parser.add_argument("--size", type=int, default=128)
    parser.add_argument("--jobs", type=int, default=1)
    parser.add_argument("--timeout", type=float, default=3600)
    parser.add_argument("--resume", action="store_true")
    parser.add_argument("--only", type=lambda text: text.split(","), default=None, metavar="SCENE,...")
    args = parser.parse_args(argv)
    scenes = [s for s in scene_files(args.out, args.size) if args.only is None or s.name in args.only]
    todo = jobs(args.out, scenes)
    run_jobs(todo, args.jobs, args.resume, args.timeout)
    rows = [row(j) for j in todo]
    write_csv(rows, args.out / "scene_race.csv")
    (args.out / "scene_race.md").write_text(report(rows, scenes))
    print(f"wrote {args.out / 'scene_race.md'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
