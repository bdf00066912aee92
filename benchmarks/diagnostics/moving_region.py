"""Where ``background=image`` saw motion: the FBP frames' spread over time, the moving region's
threshold (``background.moving_share`` of its 99.9th percentile, above the still scene's floor), the
region's connected pieces (each with the still middle it touches: `background.still_middles`) and
the spread's local peaks outside it. A mover the region misses, or holds only a sliver of, is held
still by the background (benchmarks/results/background: holes000's slower orbit before session 44).

The frames are those of the run itself: ``nct.method.reconstruct.reconstruct`` is called and
stopped where it hands them to the background's start (init_candidates.py does the same for the
segmentation). ``--png`` also draws the spread and the region.

    python benchmarks/diagnostics/moving_region.py outputs/s42/textured/scenes/holes000.npz --n-objects 2 \
        --override background=image
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
from scipy.ndimage import label
from skimage.feature import peak_local_max

from nct.errors import InputError, MethodError
from nct.init import background as bg

sys.path.insert(0, str(Path(__file__).resolve().parent))
from init_candidates import run_config, run_until  # noqa: E402

PEAK_SPACING_PX = 5  # local peaks of the spread at least this far apart: one or two per moving edge


def region_inputs(path: Path | None, n_objects: int | None, overrides: list[str]) -> tuple[np.ndarray, float]:
    """The run's FBP init frames [F, H, W] (method units) and its ``background.moving_share``
    (arguments as init_candidates.run_config's)."""
    conf = run_config(path, n_objects, overrides)
    if conf.background.name != "image":
        raise InputError("the run has no background image: add --override background=image")
    frames, share = run_until(conf, "static_start")
    return frames, share


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("path", type=Path, nargs="?", help="a sinogram file (.npz; none: the overrides' scene)")
    parser.add_argument("--n-objects", type=int, help="data.n_objects (K; default: the config's)")
    parser.add_argument("--override", action="append", default=[], metavar="KEY=VALUE", help="an nct override")
    parser.add_argument("--png", type=Path, help="also draw the spread and the region here")
    args = parser.parse_args()
    try:
        frames, share = region_inputs(args.path, args.n_objects, args.override)
    except (InputError, MethodError) as err:
        parser.exit(2, f"moving_region: error: {err}\n")
    spread = frames.std(axis=0)
    floor = bg.still_floor(frames, spread)
    top = float(np.percentile(spread, bg.PERCENTILE))
    region = bg.moving_region(frames, share)
    print(f"spread over time: 99.9th percentile {top:.3f}, floor {floor:.3f}; threshold "
          f"{bg.edge_threshold(frames, spread, share):.3f} (moving_share {share}); region {int(region.sum())} px")
    pieces, n = label(region)
    for piece in range(1, n + 1):
        rows, cols = np.nonzero(pieces == piece)
        print(f"  piece {piece}: {rows.size} px about row {rows.mean():.0f}, column {cols.mean():.0f}, "
              f"spread up to {spread[rows, cols].max():.3f}")
    for y, x in peak_local_max(spread, min_distance=PEAK_SPACING_PX, threshold_abs=floor):
        if not region[y, x]:
            print(f"  peak {spread[y, x]:.3f} at row {y}, column {x}, outside the region")
    if args.png:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, axes = plt.subplots(1, 2, figsize=(8, 4))
        axes[0].imshow(spread, cmap="magma")
        axes[0].set_title("FBP frames' spread over time")
        axes[1].imshow(region, cmap="gray")
        axes[1].set_title("moving region")
        fig.savefig(args.png, dpi=100, bbox_inches="tight")
        print(f"wrote {args.png}")


if __name__ == "__main__":
    main()
