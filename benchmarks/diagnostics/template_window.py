"""How much of a moved template's lattice a step renders: runs ``nct`` with the given overrides (a rigid or affine
rung) and counts, over every lookup, the share of the template's side x side lattice in the window its points
reach (fields/lattice.reached_window). Instrumentation only: the run is the one the overrides make.

    python benchmarks/diagnostics/template_window.py experiment=static motion=rigid seed=0 threads=2 \\
        logger=none optim.fit_steps=50 optim.init_steps=20 hydra.run.dir=outputs/diagnostics/window_static
"""

from __future__ import annotations

import sys

import numpy as np

import nct.fields.moved as moved
from nct.cli import main as cli

shares: list[float] = []
reached = moved.reached_window


def counted(where, side):
    """`reached_window`, its window's share of the lattice recorded."""
    rows, cols = reached(where, side)
    shares.append((rows.stop - rows.start) * (cols.stop - cols.start) / side**2)
    return rows, cols


if __name__ == "__main__":
    moved.reached_window = counted
    sys.argv = ["nct", *sys.argv[1:]]
    try:
        cli.main()
    except SystemExit:
        pass
    q = np.percentile(shares, [0, 50, 100]) if shares else [np.nan] * 3
    print(f"{len(shares)} lookups; window share of the lattice: min {q[0]:.2f}, median {q[1]:.2f}, max {q[2]:.2f}")
