"""The scene files scene_model.py measures, each with its truth's right scene model (read only to score a rule).

The generalisation benchmark's scenes (uniform ellipses on an empty background: none, K = every object),
the textured scenes (a static body under moving objects: a background image, K = the moving objects), the
surround scenes and the experiments written as files by ``nct experiment=X method=fbp`` (each its own
config's background and K). Files are written under the given folder where missing.
"""

from __future__ import annotations

import math
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parent))
import generalisation as gen  # noqa: E402
from init_candidates import run_config  # noqa: E402
from scene_files import write_scene  # noqa: E402
from scenes import FAMILIES, draw_scenes, draw_textured_scene  # noqa: E402
from surround import NAMES, moving_levels, surround_scenes  # noqa: E402
from textured import scene_name  # noqa: E402

from nct.run.conf import chosen_objects  # noqa: E402
from nct.scenes.phantoms import build_phantom  # noqa: E402

SETS = ("generalisation", "textured", "surround", "experiments")
EXPERIMENTS = ("thorax", "nodule", "heart_cine", "letters", "bar", "static", "circle")
RUN = ("threads=1", "logger=none", "seed=0")  # every run's overrides (the method's seed, one thread)


@dataclass(frozen=True)
class SceneFile:
    """A scene file and its truth's right model (for scoring only): ``background`` none | image and
    ``n_objects`` (K; over a background, the moving parts)."""

    name: str
    category: str
    path: Path
    background: str
    n_objects: int
    detail: str = ""
    level_gap: float = math.nan  # the closest two of the truth's levels, relative to the larger (generalisation)


def generalisation_files(out: Path, n: int = gen.FULL_SCENES, seed: int = 0,
                         size: int = gen.FULL_SIZE) -> list[SceneFile]:
    """The generalisation benchmark's first ``n`` scenes of sampler ``seed``: uniform ellipses on an empty
    background, K = every object."""
    files = []
    for s in draw_scenes(seed, n):
        path = out / "generalisation" / f"{s.name}.npz"
        if not path.is_file():
            write_scene(s, path, size, gen.FULL_FRAMES, seed)
        detail = f"{s.layout}, {' '.join(o.motion.kind for o in s.objects)}, " + ("noisy" if s.noise_i0 else "clean")
        files.append(SceneFile(s.name, "generalisation", path, "none", len(s.objects), detail, level_gap(s)))
    return files


def level_gap(scene, moving: bool = False) -> float:
    """The closest two levels of a scene's objects (``moving``: of its moving ones), a nested object's its
    container's plus its own, relative to the larger; NaN for one. Scoring only: two levels a few % apart
    are one to the data."""
    levels = sorted(o.intensity + (0.0 if o.parent is None else scene.objects[o.parent].intensity)
                    for o in scene.objects if not moving or o.motion.kind != "static")
    return min((b - a) / b for a, b in zip(levels, levels[1:])) if len(levels) > 1 else math.nan


def textured_files(out: Path, per_family: int = 3, size: int = gen.FULL_SIZE) -> list[SceneFile]:
    """The textured benchmark's scenes (``textured.py``): a static image under K moving objects."""
    files = []
    for family in FAMILIES:
        for i in range(per_family):
            s = draw_textured_scene(0, family, i)
            path = out / "textured" / f"{scene_name(s)}.npz"
            if not path.is_file():
                write_scene(s, path, size, gen.FULL_FRAMES, 0, level=0.5 * s.objects[0].intensity)
            motions = " ".join(o.motion.kind for o in s.objects if o.motion.kind != "static")
            files.append(SceneFile(scene_name(s), "textured", path, "image", len(moving_levels(s)),
                                   f"{family}, {motions}", level_gap(s, moving=True)))
    return files


def surround_files(out: Path, size: int = gen.FULL_SIZE) -> list[SceneFile]:
    """``surround.py``'s scenes: the vessel in a body (a static image under one mover, as issue 47 ran it)
    and the disc beside a still one (two uniform objects on an empty background)."""
    truth = {"vessel": ("image", 1, "nested, orbit in a static body"), "beside": ("none", 2, "apart, orbit + static")}
    files = []
    for name, s in zip(NAMES, surround_scenes(720)):
        path = out / "surround" / f"{name}.npz"
        if not path.is_file():
            write_scene(s, path, size, 12, 0)
        files.append(SceneFile(name, "surround", path, *truth[name]))
    return files


def scene_files(out: Path, sets: list[str], n_generalisation: int = gen.FULL_SCENES, seed: int = 0) -> list[SceneFile]:
    """The files of ``sets`` (written where missing; the generalisation scenes: the first ``n_generalisation``
    of sampler ``seed``)."""
    makers = {"generalisation": lambda: generalisation_files(out, n_generalisation, seed),
              "textured": lambda: textured_files(out),
              "surround": lambda: surround_files(out), "experiments": lambda: experiment_files(out)}
    return [f for name in sets for f in makers[name]()]


def experiment_files(out: Path, names: tuple[str, ...] = EXPERIMENTS) -> list[SceneFile]:
    """The experiments as files (``nct experiment=X method=fbp`` writes sinogram.npz with the truth); the
    right model is the experiment's own: an image where its config sets ``background=image`` (none where it
    leaves it to the data), and K its ``data.n_objects`` where set, else one per level of the phantom."""
    files = []
    for name in names:
        folder = out / "experiments" / name
        if not (folder / "sinogram.npz").is_file():
            subprocess.run([str(Path(sys.executable).parent / "nct"), f"experiment={name}", "method=fbp", *RUN,
                            f"hydra.run.dir={folder}"], check=True, stdout=subprocess.DEVNULL)
        conf = run_config(None, None, [f"experiment={name}"])
        levels = len(build_phantom(conf.phantom, conf.scanner.rotation_time).intensities)
        background = "image" if conf.background.name == "image" else "none"
        files.append(SceneFile(name, "experiment", folder / "sinogram.npz", background,
                               chosen_objects(conf.data.n_objects) or levels, name))
    return files
