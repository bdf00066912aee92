"""Overlap of the tiny small-object scene (tests/method/test_segment) over seeds: python smalls.py ROOT A:B [init_steps] [I0]."""
import logging
import sys

import numpy as np
import torch

root = sys.argv[1]; sys.path.insert(0, root); sys.path.insert(0, root + "/src")
torch.set_num_threads(1)
logging.basicConfig(level=logging.WARNING)
for n in ("lightning", "lightning.pytorch", "lightning.fabric"): logging.getLogger(n).setLevel(logging.ERROR)
from dataclasses import replace

import tests.conftest as C
from nct.acquisition.scanner import ImageGrid, Scanner
from nct.fit.conf import LossConf
from nct.method.reconstruct import reconstruct
from nct.run.metrics import dice
from nct.scenes.phantoms import ComposedConf, build_phantom
from nct.scenes.simulate import simulate

GRID = ImageGrid(40)
seeds = range(*map(int, sys.argv[2].split(':'))); steps = int(sys.argv[3]) if len(sys.argv) > 3 else 30
noise = float(sys.argv[4]) if len(sys.argv) > 4 else None
objects = [C.orbit(0.05, 0.2, 60.0, 1.0)]
scanner = Scanner(views_per_rotation=120, rotations=1.0, rotation_time=0.25, n_bins=40, bin_spacing=1 / 40)
ph = build_phantom(ComposedConf(objects=objects), scanner.rotation_time)
times = scanner.frame_times(6)
sino = simulate(ph, scanner, GRID, times, noise, np.random.default_rng(0))
out=[]
for seed in seeds:
  res = reconstruct(sino, GRID, times, C.MODEL, LossConf(), C.TRAINER, seed, log_dir=None, logger="none",
                    n_objects=1, optim=replace(C.LONGER, init_steps=steps), init=C.INIT)
  t = sino.truth.frames
  v = np.median(dice(res.frames >= 0.5 * min(res.intensities), t >= sino.truth.level))
  st = res.stages
  im = [round(x.get('misfit', -1), 3) for k, x in st.items() if k.endswith('init')]
  out.append(round(float(v), 3)); print(seed, 'initmisfit', im, 'dice', out[-1], flush=True)
print(root, out, np.mean(out))
