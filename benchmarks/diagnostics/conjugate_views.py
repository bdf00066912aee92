"""Does a sinogram alone say that nothing moves? Conjugate views, over the benchmarks' scene files (issue 48 bar 4).

A still object is seen twice along every line in half a turn: in parallel beam p(theta + pi, s) = p(theta, -s),
and motion between the two instants breaks it. Per file (fan beam rebinned to parallel): each view against its
conjugate half a turn later (interpolated linearly in angle), relative to the views' norm (``conjugate``), and each
view against the mean of its two neighbours (``neighbour``: the noise and the interpolation's error, the yardstick).
A still scene's ``ratio`` (conjugate / neighbour) sits near or below 1 (noise alone), a moving one's far above. Truth is read only
to label the rows (``still``: every object of the scene still). Nothing here is used by the method.
Run: python benchmarks/diagnostics/conjugate_views.py --out benchmarks/results/speed/conjugate_views [--files DIR]
"""

from __future__ import annotations

import argparse
import csv
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from scene_model_files import scene_files  # noqa: E402

from nct.acquisition.io import load_sinogram  # noqa: E402
from nct.acquisition.rebin import to_parallel  # noqa: E402
from nct.acquisition.sinogram import Sinogram  # noqa: E402


def consistency(sino: Sinogram) -> tuple[float, float]:
    """(conjugate, neighbour): the norms of each view minus its mirrored conjugate half a turn later, and of each
    view minus its neighbours' mean, over the views' norm, over the views that have a conjugate; NaN under half a
    turn."""
    sino = sino if sino.geometry.is_parallel else to_parallel(sino)
    values = np.asarray(sino.values, dtype=np.float64)
    angles = np.unwrap(np.asarray(sino.angles, dtype=np.float64))  # a file's angles may wrap at a turn
    turn = np.abs(angles - angles[0])  # rad from the first view
    target = turn + np.pi
    has = np.flatnonzero(target <= turn[-1])
    if len(has) < 2:
        return float("nan"), float("nan")
    at = np.interp(target[has], turn, np.arange(len(turn)))  # fractional index of each conjugate
    low = np.floor(at).astype(int)
    high = np.minimum(low + 1, len(turn) - 1)
    w = (at - low)[:, None]
    conjugate = (1 - w) * values[low] + w * values[high]
    norm = np.linalg.norm(values[has])
    mirrored = np.linalg.norm(conjugate - values[has, ::-1]) / norm
    inner = has[(has > 0) & (has < len(turn) - 1)]
    neighbour = np.linalg.norm(values[inner] - 0.5 * (values[inner - 1] + values[inner + 1])) / norm
    return float(mirrored), float(neighbour)


def still(detail: str, name: str, category: str) -> bool:
    """Whether a scene file's truth holds nothing moving: every object of a generalisation scene 'static', the
    still experiment; the textured and surround scenes each move."""
    if category == "generalisation":
        return all(kind == "static" for kind in detail.split(", ")[1].split())
    return category == "experiment" and name == "static"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--files", type=Path, default=Path("outputs/scene_model"),
                        help="where the scene files are (written where missing)")
    parser.add_argument("--out", type=Path, required=True)
    args = parser.parse_args()
    rows = []
    for f in scene_files(args.files, ["generalisation", "textured", "surround", "experiments"]):
        conjugate, neighbour = consistency(load_sinogram(f.path))
        rows.append({"name": f.name, "category": f.category, "detail": f.detail,
                     "still": still(f.detail, f.name, f.category), "conjugate": conjugate, "neighbour": neighbour,
                     "ratio": conjugate / neighbour if neighbour > 0 else float("nan")})
    args.out.mkdir(parents=True, exist_ok=True)
    with open(args.out / "files.csv", "w", newline="") as out:
        writer = csv.DictWriter(out, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    for label, keep in (("still", True), ("moving", False)):
        ratios = np.array([r["ratio"] for r in rows if r["still"] == keep and np.isfinite(r["ratio"])])
        print(f"{label}: {len(ratios)} files, ratio min {ratios.min():.3g} median {np.median(ratios):.3g} "
              f"max {ratios.max():.3g}" if len(ratios) else f"{label}: none")


if __name__ == "__main__":
    main()
