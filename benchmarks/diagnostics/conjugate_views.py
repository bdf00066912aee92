"""Does a sinogram alone say that nothing moves? Conjugate views, over the benchmarks' scene files (issue 48 bar 4).

A still object is seen twice along every line in half a turn: in parallel beam p(theta + pi, s) = p(theta, -s),
and motion between the two instants breaks it. Per file (fan beam rebinned to parallel): each view against its
conjugate half a turn later (interpolated linearly in angle), relative to the views' norm (``conjugate``), and each
view against the mean of its two neighbours (``neighbour``: the noise and the interpolation's error, the yardstick).
A still scene's ``ratio`` (conjugate / neighbour) sits near or below 1 (noise alone), a moving one's far above
(nct.moments.conjugates, which the tournament reads: motion.still_ratio). Truth is read only to label the rows
(``still``: every object of the scene still).
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
from nct.moments.conjugates import conjugate_mismatch  # noqa: E402


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
        conjugate, neighbour = conjugate_mismatch(load_sinogram(f.path))
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
