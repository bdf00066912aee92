"""Static against free on the tests' disc held still, seeds 0-3: which rung the tournament chooses, and each
candidate's held-out misfit and steps (the tests' tiny settings, one thread).
Run: python benchmarks/diagnostics/still.py (from the repo root)
"""

from __future__ import annotations

import sys
from dataclasses import replace
from pathlib import Path

import torch

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))
from nct.acquisition.scanner import ImageGrid, Scanner  # noqa: E402
from nct.fit.conf import LossConf  # noqa: E402
from nct.method.reconstruct import reconstruct  # noqa: E402
from nct.scenes.phantoms import CircleConf, build_phantom  # noqa: E402
from nct.select.conf import SelectionConf  # noqa: E402
from tests.conftest import INIT, MODEL, NO_BACKGROUND, OPTIM, TRAINER, moving_disc  # noqa: E402

GRID = ImageGrid(32)


def main() -> None:
    torch.set_num_threads(1)
    sino, times = moving_disc(GRID)
    scanner = Scanner(views_per_rotation=60, rotations=1.0, rotation_time=0.25, n_bins=32, bin_spacing=1 / 32)
    held = build_phantom(CircleConf(radius=0.2, orbit_radius=0.15, displacement_deg=0.0), scanner.rotation_time)
    still = replace(sino, values=held.project(scanner, GRID))
    for seed in range(4):
        result = reconstruct(still, GRID, times, MODEL, LossConf(), TRAINER, seed, log_dir=None, logger="none",
                             optim=OPTIM, init=INIT, background=NO_BACKGROUND,
                             motion=SelectionConf(rungs=["static", "free"]))
        table = [(row["candidate"], round(row["heldout_misfit"], 4), row["steps"]) for row in result.selection["table"]]
        print(seed, result.selection["winner"], table)


if __name__ == "__main__":
    main()
