"""Static against free on the tests' still disc, seeds 0-3: python benchmarks/diagnostics/still.py (from the repo root)."""
import sys; sys.path.insert(0, "."); sys.path.insert(0, "src")
import torch; torch.set_num_threads(1)
from dataclasses import replace

import tests.method.test_reconstruct as T
from nct.select.conf import SelectionConf
from tests.conftest import moving_disc

sino, truth = moving_disc()
import numpy as np

times = np.linspace(0, 0.25, 7)[:-1] + 0.25 / 12
from nct.acquisition.scanner import Scanner
from nct.scenes.phantoms import CircleConf, build_phantom

ph = build_phantom(CircleConf(radius=0.2, orbit_radius=0.15, displacement_deg=0.0), 0.25)
sc = Scanner(views_per_rotation=60, rotations=1.0, rotation_time=0.25, n_bins=32, bin_spacing=1 / 32)
still = replace(sino, values=ph.project(sc, T.GRID))
for seed in range(4):
    r = T.run(still, times, seed=seed, motion=SelectionConf(rungs=["static", "free"]))
    print(seed, r.selection["winner"], [(x["candidate"], round(x["heldout_misfit"], 4), x["steps"]) for x in r.selection["table"]])
