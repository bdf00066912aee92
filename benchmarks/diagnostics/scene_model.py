"""Which scene model a file's data propose before any fit (issue 47): truth-free signals for K and the background.

For each scene file, from the run's own first steps (fit/problem.prepare, the background's start, Algorithm 1's
mixture and the sinogram judge: init/starts.sought and search, called as select/scene.set_up calls them):
the Gaussian mixture's BIC/AIC over component counts on the FBP frames; how many distinct levels
Algorithm 1 finds above the foreground threshold; the judge's relative residual of the best
segmentation at K = 1..MAX_OBJECTS (4) without a background, on the plain FBP frames (``none``) and, where the
views hold one steady mover's path, on the frames with its translation undone (``lone``: a run with
K = 1 segments those), and over the background's start (K = 0: the start alone; K >= 1: the
objects sought in what moves), all relative to the same fitted views (``r_image0``: the norm of the
views minus the background's projection over theirs), with the least interior share of each
segmentation's objects (a rim or streak has next to none); the noise's own residual and the FBP
frames'; the moving region's share; each signal's seconds (one thread). One row per file in
``signals.csv``; the truth's model (scoring only, never read by a signal) rides along.
``scene_model_rule.py`` scores the product's choice of scene model (select/scene.py) on the table.

The files (under ``--out``, written where missing; one already in the table is skipped): the generalisation
benchmark's scenes, the textured and surround scenes, and the experiments written by ``nct experiment=X method=fbp``.

    OMP_NUM_THREADS=1 python benchmarks/diagnostics/scene_model.py --out outputs/scene_model [--sets generalisation
        textured surround experiments] [--scenes N] [--only scene000,holes001] [--table other.csv]
"""

from __future__ import annotations

import argparse
import csv
import math
import sys
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path

import numpy as np
import torch
from scipy.ndimage import binary_dilation, maximum_filter, minimum_filter
from sklearn.mixture import GaussianMixture
from threadpoolctl import threadpool_limits

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parent))
import generalisation as gen  # noqa: E402
from init_candidates import run_config  # noqa: E402
from scene_model_files import RUN, SETS, SceneFile, scene_files  # noqa: E402

from nct.errors import NoObjectError  # noqa: E402
from nct.fit.problem import Problem, prepare  # noqa: E402
from nct.init.background import moving_problem, static_start  # noqa: E402
from nct.init.conf import InitConf  # noqa: E402
from nct.init.foreground import noise_sigma  # noqa: E402
from nct.init.judge import views_norm  # noqa: E402
from nct.init.mixture import algorithm1_levels, mixture_classes  # noqa: E402
from nct.init.segmentation import Segmentation  # noqa: E402
from nct.init.starts import judge_of, search, sought  # noqa: E402
from nct.physics.data_term import MAD_TO_STD  # noqa: E402
from nct.run.pipeline import acquire  # noqa: E402
from nct.run.schema import NCTConf  # noqa: E402
from nct.run.tables import write_csv  # noqa: E402
from nct.select.scene import MAX_OBJECTS  # noqa: E402

MAX_COMPONENTS = 8  # the mixture's BIC/AIC over 1..MAX_COMPONENTS components
EDGE_PX = 2  # the texture's pixels lie this far from any boundary between the segmentation's regions


@dataclass
class Timer:
    """Seconds spent per signal (one thread), by name."""

    seconds: dict[str, float] = field(default_factory=dict)

    def __call__(self, name: str, work: Callable, *args, **kwargs):
        start = time.perf_counter()
        try:
            return work(*args, **kwargs)
        finally:
            self.seconds[name] = self.seconds.get(name, 0.0) + time.perf_counter() - start


def problems(path: Path, timer: Timer) -> tuple[Problem, Problem, NCTConf]:
    """The file's ``Problem`` as a run prepares it (select/scene.Preparation) with K >= 2 or a background (plain
    FBP frames) and with K = 1 and none (``lone``: a steady mover's translation undone), and the config."""
    conf = run_config(path, None, list(RUN))
    scan = acquire(conf, np.random.default_rng(conf.seed))
    args = (scan.sinogram, scan.grid, conf.loss, conf.init, conf.heldout, conf.fbp.filter, conf.fbp.window_deg)
    plain = timer("prepare", prepare, *args)
    lone = timer("prepare_lone", prepare, *args, lone=True)
    return plain, lone, conf


def judged_norm(prob: Problem, k: int) -> float:
    """The norm of the fitted views the judge compares K masks with (judge.views_norm): a residual relative to one
    problem's views becomes one relative to another's."""
    return views_norm(prob.views.values[torch.from_numpy(prob.fit_views)], k * prob.grid.size**2)


def noise_floor(prob: Problem) -> float:
    """The judge's relative residual that noise alone would leave: the fitted views' noise std per bin (each
    view against its neighbours' mean, median over views: `suspect.noise_misfit`'s estimate), as an rms,
    over the views' rms."""
    v = prob.views.values[torch.from_numpy(prob.fit_views)].double().numpy()
    wiggle = np.abs(v[1:-1] - 0.5 * (v[:-2] + v[2:])) / math.sqrt(1.5)
    std = MAD_TO_STD * np.median(wiggle, axis=0)
    return float(np.sqrt(np.mean(std**2) / max(float(np.mean(v**2)), 1e-30)))


def fbp_residual(prob: Problem, init: InitConf) -> float:
    """The judge's relative residual of the FBP frames themselves (one scale fitted): what a free pixel image
    per frame explains of the fitted views, motion smear and FBP's own errors included."""
    return judge_of(prob, init)(prob.fbp[:, None], np.ones(1))[0]


def best_segmentation(prob: Problem, k: int, conf: NCTConf, background: str = "none") -> Segmentation | None:
    """The judge's best segmentation into K objects of ``prob``'s FBP frames (over a ``background`` image: of what
    moves, init/starts.sought), as select/scene.set_up finds a model's (the seed's generator); None where nothing
    stands out."""
    where = sought(prob, k, conf.init, replace(conf.background, name=background))
    try:
        return search(where, k, conf.init, np.random.default_rng(conf.seed)).ranked[0]
    except NoObjectError:
        return None


def mixture_counts(frames: np.ndarray, conf: NCTConf) -> tuple[int, int]:
    """Components (1..MAX_COMPONENTS) of the Gaussian mixture on Algorithm 1's sample of the frames
    that minimise BIC and AIC."""
    rng = np.random.default_rng(conf.seed)
    n_fit = max(1, int(round(conf.init.gmm_share * len(frames))))
    sample = frames[rng.choice(len(frames), size=n_fit, replace=False)].reshape(-1, 1).astype(np.float64)
    bic, aic = [], []
    with threadpool_limits(1):
        for n in range(1, MAX_COMPONENTS + 1):
            gmm = GaussianMixture(n, n_init=3, random_state=conf.seed).fit(sample)
            bic.append(gmm.bic(sample))
            aic.append(gmm.aic(sample))
    return int(np.argmin(bic)) + 1, int(np.argmin(aic)) + 1


def mixture_levels(frames: np.ndarray, conf: NCTConf) -> tuple[int, int]:
    """Algorithm 1's mixture with MAX_OBJECTS objects' classes: the most distinct levels its rule finds above the
    foreground threshold, and the classes whose means lie above it."""
    classes = mixture_classes(frames, MAX_OBJECTS, np.random.default_rng(conf.seed), conf.init.kappa,
                              conf.init.gmm_share)
    found = max((k for k in range(1, MAX_OBJECTS + 1) if algorithm1_levels(classes, k) is not None), default=0)
    above = int(sum(classes.means[c] >= classes.lowest for c in range(len(classes.means)) if c != classes.background))
    return found, above


def interior_share(masks: np.ndarray) -> float:
    """The least share, over the objects of ``masks`` [F, K, H, W] bool, of an object's pixels whose four
    neighbours are in its mask too: a body has an inside, a partial-volume rim or a streak 1-2 px wide has
    next to none."""
    inner = masks.copy()
    inner[..., 1:, :] &= masks[..., :-1, :]
    inner[..., :-1, :] &= masks[..., 1:, :]
    inner[..., :, 1:] &= masks[..., :, :-1]
    inner[..., :, :-1] &= masks[..., :, 1:]
    return float(min(inner[:, k].sum() / max(1, masks[:, k].sum()) for k in range(masks.shape[1])))


def judged(prefix: str, k: int, s: Segmentation | None, scale: float = 1.0) -> dict:
    """A judged segmentation's columns: the residual (times ``scale``: relative to the whole views), a(k),
    each object's pixels per frame and the least interior share of its objects (`interior_share`)."""
    if s is None:
        return {f"r_{prefix}{k}": math.nan, f"a_{prefix}{k}": "", f"px_{prefix}{k}": "",
                f"inside_{prefix}{k}": math.nan}
    pixels = s.masks.sum(axis=(0, 2, 3)) / len(s.masks)
    return {f"r_{prefix}{k}": s.misfit * scale, f"a_{prefix}{k}": " ".join(f"{a:.3g}" for a in s.intensities),
            f"px_{prefix}{k}": " ".join(f"{p:.0f}" for p in pixels), f"inside_{prefix}{k}": interior_share(s.masks)}


def texture(frames: np.ndarray, s: Segmentation | None, moving: np.ndarray) -> tuple[float, float]:
    """How far the still part of the FBP frames' mean is from piecewise constant: the rms, over the pixels
    inside the objects, outside the ``moving`` region [H, W] and EDGE_PX or more from any boundary between
    ``s``'s regions (each pixel's set of masks held over half the frames), of the mean minus its region's
    median; and the mean's pixel noise (foreground.noise_sigma), what a uniform object leaves besides FBP's
    ripple. A graded body, or structures that no level of ``s`` holds, leave their contrast."""
    mean = frames.mean(axis=0)
    noise = noise_sigma(mean)
    if s is None:
        return math.nan, noise
    regions = sum((s.masks[:, k].mean(axis=0) > 0.5).astype(int) << k for k in range(s.masks.shape[1]))
    edges = maximum_filter(regions, 2 * EDGE_PX + 1) != minimum_filter(regions, 2 * EDGE_PX + 1)
    keep = (regions > 0) & ~edges & ~binary_dilation(moving, iterations=EDGE_PX)
    if not keep.any():
        return math.nan, noise
    medians = np.zeros(int(regions.max()) + 1)
    for r in np.unique(regions[keep]):
        medians[r] = np.median(mean[keep & (regions == r)])
    return float(np.sqrt(np.mean((mean[keep] - medians[regions[keep]]) ** 2))), noise


def signals(scene: SceneFile, k_max: int = MAX_OBJECTS) -> dict:
    """One file's row: the truth's model (scoring only), the signals at K = 1..``k_max`` (a run's: 1..MAX_OBJECTS)
    and their seconds (one thread)."""
    torch.set_num_threads(1)
    timer = Timer()
    plain, lone, conf = problems(scene.path, timer)
    row = {k: v for k, v in asdict(scene).items() if k != "path"}
    row.update(views=len(plain.views.values), frames=len(plain.fbp), rotations=plain.span,
               noise=noise_sigma(plain.fbp), noise_floor=timer("floor", noise_floor, plain),
               r_fbp=timer("fbp", fbp_residual, plain, conf.init))
    row["bic_components"], row["aic_components"] = timer("bic", mixture_counts, plain.fbp, conf)
    row["mixture_levels"], row["classes_above"] = timer("mixture", mixture_levels, plain.fbp, conf)
    held = lone.centres is not None
    for k in range(1, k_max + 1):  # the plain frames at every K; a steady mover's compensated ones, where held
        most = timer(f"none{k}", best_segmentation, plain, k, conf)
        row.update(judged("none", k, most))
        row.update(judged("lone", k, timer(f"lone{k}", best_segmentation, lone, k, conf) if held else None))
    start = timer("static", static_start, plain.fbp, conf.background.moving_share)
    row["texture"], row["mean_noise"] = timer("texture", texture, plain.fbp, most, start.moving)
    moved = timer("static", moving_problem, plain, start)
    row.update(moving_share=float(start.moving.mean()), r_image0=judged_norm(moved, 1) / judged_norm(plain, 1))
    for k in range(1, k_max + 1):  # over the same start, sought as a run does (one object: on its focused path)
        s = timer(f"image{k}", best_segmentation, plain, k, conf, "image") if start.moving.any() else None
        row.update(judged("image", k, s, judged_norm(moved, k) / judged_norm(plain, k)))
    return {**row, **{f"t_{name}": s for name, s in timer.seconds.items()}}


def read_rows(path: Path) -> list[dict]:
    """The rows of an earlier call's signals.csv (none if absent)."""
    if not path.is_file():
        return []
    with open(path, newline="") as fh:
        return list(csv.DictReader(fh))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, required=True, help="scene files and signals.csv go here")
    parser.add_argument("--sets", nargs="+", default=list(SETS), choices=SETS)
    parser.add_argument("--scenes", type=int, default=gen.FULL_SCENES, help="generalisation scenes (the first N)")
    parser.add_argument("--seed", type=int, default=0, help="the generalisation scenes' sampler seed (default 0)")
    parser.add_argument("--only", type=lambda text: text.split(","), metavar="NAME,...", help="these files only")
    parser.add_argument("--table", type=Path, help="the rows go here (default OUT/signals.csv; another: files "
                        "already in that table measured again, to compare, without touching it)")
    args = parser.parse_args(argv)
    files = [f for f in scene_files(args.out, args.sets, args.scenes, args.seed)
             if not args.only or f.name in args.only]
    table = args.table or args.out / "signals.csv"
    rows = read_rows(table)
    done = {r["name"] for r in rows}
    for f in files:
        if f.name in done:
            continue
        rows.append(signals(f))
        write_csv_rows(rows, table)
        print(f"{f.name}: " + ", ".join(f"{k} {rows[-1][k]:.3g}" for k in rows[-1] if k.startswith("r_")), flush=True)
    print(f"wrote {table} ({len(rows)} files)")
    return 0


def write_csv_rows(rows: list[dict], path: Path) -> None:
    """signals.csv, columns in the first full row's order (an earlier call's rows are read back as text)."""
    columns = list(dict.fromkeys(k for r in sorted(rows, key=len, reverse=True) for k in r))
    write_csv(rows, path, columns)


if __name__ == "__main__":
    sys.exit(main())
