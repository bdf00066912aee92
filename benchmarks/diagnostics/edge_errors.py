"""Where a textured run's own-level Dice is lost: at each moving object's own level, the pixels drawn
above it that the truth has below (false positives) and the reverse (false negatives), per frame, by
their distance in pixels from the truth's boundary at that level, and the run's a(k). An object drawn
a fraction of a pixel too large shows as false positives at distance 1 alone
(benchmarks/results/background, session 46: holes000 over a background against without one). Over a
background, also its plateau under each mover: its mean where the mover always lies above the lowest
level, less its mean on the ring of RING_PX pixels about where the mover ever lies.

Reads what benchmarks/textured.py wrote in its ``--out`` (scenes/<scene>.npz, runs/<scene>/<background>/);
the levels are those textured.py scores (surround.moving_levels of the scene drawn with ``--seed``).

    python benchmarks/diagnostics/edge_errors.py outputs/s45/textured holes000
"""

from __future__ import annotations

import argparse
import json
import sys
from collections import Counter
from pathlib import Path

import numpy as np
from scipy.ndimage import binary_dilation, distance_transform_edt, label

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from scenes import FAMILIES, draw_textured_scene  # noqa: E402
from surround import moving_levels  # noqa: E402

FAR_PX = 3  # errors this far from the boundary or farther are counted together: a shape gone wrong, not an edge
RING_PX = 2  # a plateau is measured against the background this close about the mover's reach


def edge_errors(rec: np.ndarray, truth: np.ndarray, level: float) -> tuple[Counter, Counter]:
    """False positives and negatives of ``rec`` [F, H, W] against ``truth`` [F, H, W] thresholded at
    ``level``, counted by their rounded distance (px, capped at FAR_PX) from the truth's boundary."""
    fp, fn = Counter(), Counter()
    for r, t in zip(rec, truth):
        inside = t >= level
        out_dist, in_dist = distance_transform_edt(~inside), distance_transform_edt(inside)
        fp.update(np.minimum(np.rint(out_dist[(r >= level) & ~inside]), FAR_PX).astype(int).tolist())
        fn.update(np.minimum(np.rint(in_dist[(r < level) & inside]), FAR_PX).astype(int).tolist())
    return fp, fn


def plateaus(background: np.ndarray, truth: np.ndarray, level: float) -> list[tuple[int, float]]:
    """Per piece of where ``truth`` [F, H, W] ever lies above ``level``: the pixels it always does
    and the ``background`` [H, W]'s mean there less its mean on the RING_PX ring about the piece."""
    always, pieces = (truth >= level).all(axis=0), label((truth >= level).any(axis=0))[0]
    out = []
    for piece in range(1, pieces.max() + 1):
        reach = pieces == piece
        ring = binary_dilation(reach, iterations=RING_PX) & ~reach
        middle = reach & always
        if middle.any():
            out.append((int(middle.sum()), float(background[middle].mean() - background[ring].mean())))
    return out


def scene_of(name: str, seed: int):
    """The textured scene ``name`` (family + three-digit index) as textured.py draws it with ``seed``."""
    family, index = name[:-3], name[-3:]
    if family not in FAMILIES or not index.isdigit():
        raise SystemExit(f"{name}: not a textured scene's name (a family of {', '.join(FAMILIES)} and three digits)")
    return draw_textured_scene(seed, family, int(index))


def per_frame(counts: Counter, frames: int) -> str:
    """``counts`` by distance as 'd px: n per frame' items."""
    return ", ".join(f"{d}{'+' if d == FAR_PX else ''} px {counts[d] / frames:.1f}" for d in range(1, FAR_PX + 1))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path, help="textured.py's --out")
    parser.add_argument("scenes", nargs="+", help="scene names, e.g. holes000")
    parser.add_argument("--seed", type=int, default=0, help="textured.py's --seed")
    args = parser.parse_args(argv)
    for name in args.scenes:
        levels = list(moving_levels(scene_of(name, args.seed)).values())
        scene_file = args.out / "scenes" / f"{name}.npz"
        runs = sorted((args.out / "runs" / name).glob("*/reconstruction.npz"))
        if not scene_file.is_file() or not runs:
            raise SystemExit(f"{name}: no scene file or reconstruction under {args.out}")
        with np.load(scene_file) as data:
            truth = data["truth"]
        for run in runs:
            with np.load(run) as rec:
                frames, background = rec["nct"], rec.get("nct_background")
            levels_k = json.loads((run.parent / "metrics.json").read_text()).get("intensities")
            print(f"{name}, background={run.parent.name}: a(k) {levels_k}")
            if background is not None:
                print("  the background's plateau under each mover's always-covered middle (px, height): "
                      + "; ".join(f"{n} px, {h:+.3f}" for n, h in plateaus(background, truth, min(levels))))
            for level in levels:
                fp, fn = edge_errors(frames, truth, level)
                print(f"  level {level:.3f}: false positives {per_frame(fp, len(truth))}; "
                      f"false negatives {per_frame(fn, len(truth))}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
