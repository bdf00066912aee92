"""Why fast motion fails (issue 9, item 3): what the field can hold, and what the data can tell.

A diagnosis, not a reconstruction; it reads the truth on purpose. For the paper's circle scene at
each displacement (deg of orbit per gantry rotation), on the default scanner (720 views, 128 bins):

- ``held``: the default field family (model/siren, the given F_max) fitted by L1 straight to the
  true SDF frames (60 per rotation) on a ``size``² lattice: the median and lowest Dice of its zero
  level against the true masks. What the model class can represent, with no tomography involved.
- ``floor``: the relative L1 sinogram misfit (the method's held-out score: mean |rendered -
  measured| over the sinogram's mean |value|) of the exact truth, its analytic SDF rendered by the
  method's renderer at the final band, against the analytically simulated views (every 10th view),
  on a 64² and a 128² lattice: the best score any field can reach at that lattice.

A NeuralCT run that ends with a held-out loss well above ``floor`` has not found a field that
explains the data as well as the truth does; one at or below it with a low Dice has found another
field that explains the data as well (the data do not decide).

Run: python benchmarks/diagnostics/fast_motion.py [--displacements 100 150 200] [--f-max 0.3 1.0] [--size 64]
     [--steps 1500] [--out benchmarks/results/fast_motion]
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
import torch
from scipy.ndimage import distance_transform_edt

from nct.acquisition.scanner import ImageGrid, Scanner
from nct.fields.build import build_field
from nct.fields.conf import ModelConf
from nct.fields.lattice import lattice_points
from nct.fit.render import project_frames
from nct.run.metrics import dice
from nct.run.tables import markdown_table, write_csv
from nct.scenes.phantoms import CircleConf, build_phantom

SCANNER = Scanner()  # the default: 720 views of 128 bins, one rotation of 0.25 s
FRAMES_PER_ROTATION = 60
HELD_EVERY = 10
BAND_PX, MU = 1.0, 50.0  # render/default.yaml's final band and slope


def true_sdf(conf: CircleConf, times_rot: np.ndarray, size: int) -> np.ndarray:
    """The disc's exact SDF (positive inside, FOV sides) on a size² lattice at times in rotations: [T, P]."""
    pts = lattice_points(size).numpy() * 0.5  # [-1, 1] -> unit field of view, x right, y up
    phase = 2 * math.pi * conf.displacement_deg / 360 * times_rot
    cx = conf.orbit_radius * np.cos(phase + math.radians(conf.start_deg))
    cy = conf.orbit_radius * np.sin(phase + math.radians(conf.start_deg))
    return conf.radius - np.hypot(pts[None, :, 0] - cx[:, None], pts[None, :, 1] - cy[:, None])


def held(displacement: float, f_max: float, size: int, steps: int, seed: int = 0) -> tuple[float, float]:
    """Median and lowest Dice of the default field fitted straight to the true SDF frames."""
    times = (np.arange(FRAMES_PER_ROTATION) + 0.5) / FRAMES_PER_ROTATION
    phantom = build_phantom(CircleConf(displacement_deg=displacement), SCANNER.rotation_time)
    grid = ImageGrid(size, 1.0)
    masks = np.stack([phantom.image(t * SCANNER.rotation_time, grid, 2) > 0.5 for t in times])
    # Distances from the area-sampled masks, as Algorithm 2 would see them: [T, 1, P] in FOV sides.
    target = np.stack([(distance_transform_edt(m) - distance_transform_edt(~m)) / size for m in masks])
    target_t = torch.tensor(target.reshape(len(times), 1, -1), dtype=torch.float32)
    torch.manual_seed(seed)
    net = build_field(replace(ModelConf(), f_max=f_max), 1, torch.Generator().manual_seed(seed))
    opt = torch.optim.Adam(net.shape_parameters(), 1e-3)
    t = torch.tensor(times, dtype=torch.float32)
    for _ in range(steps):
        loss = (net.sdf(net.on_lattice(size), t) - target_t).abs().mean()
        opt.zero_grad()
        loss.backward()
        opt.step()
    with torch.no_grad():
        fitted = net.sdf(net.on_lattice(size), t).reshape(len(times), size, size).numpy()
    scores = dice(fitted > 0, masks)
    return float(np.median(scores)), float(np.min(scores))


def floor(displacement: float, size: int) -> float:
    """Relative L1 misfit of the exact truth rendered on a size² lattice against the simulated views."""
    conf = CircleConf(displacement_deg=displacement)
    phantom = build_phantom(conf, SCANNER.rotation_time)
    values = phantom.project(SCANNER, ImageGrid(size, 1.0))
    views = np.arange(0, SCANNER.n_views, HELD_EVERY)
    sdf = true_sdf(conf, SCANNER.times[views] / SCANNER.rotation_time, size)
    sdf_t = torch.tensor(sdf, dtype=torch.float32).reshape(len(views), 1, size, size)
    with torch.no_grad():
        rendered = project_frames(sdf_t, torch.ones(1), torch.tensor(SCANNER.angles[views], dtype=torch.float32),
                                  SCANNER.geometry, 1.0, BAND_PX / size, MU)
    measured = torch.tensor(values[views])
    return float((rendered - measured).abs().mean() / torch.tensor(values).abs().mean())


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--displacements", type=float, nargs="+", default=[100.0, 150.0, 200.0])
    parser.add_argument("--f-max", type=float, nargs="+", default=[0.3, 1.0])
    parser.add_argument("--size", type=int, default=64)
    parser.add_argument("--steps", type=int, default=1500)
    parser.add_argument("--out", type=Path, default=Path("benchmarks/results/fast_motion"))
    args = parser.parse_args()
    torch.set_num_threads(1)
    start = time.perf_counter()
    rows = []
    for d in args.displacements:
        row = {"displacement_deg": d, "floor_64": floor(d, 64), "floor_128": floor(d, 128)}
        for f in args.f_max:
            row[f"held_median_fmax{f:g}"], row[f"held_min_fmax{f:g}"] = held(d, f, args.size, args.steps)
        rows.append(row)
        print({k: round(v, 4) for k, v in row.items()}, flush=True)
    args.out.mkdir(parents=True, exist_ok=True)
    write_csv(rows, args.out / "fast_motion.csv")
    header = list(rows[0])
    table = markdown_table(header, [[f"{r[k]:.4g}" for k in header] for r in rows])
    (args.out / "fast_motion.md").write_text(
        "# Fast motion: what the field holds, what the data tell\n\n"
        "Command: `python benchmarks/diagnostics/fast_motion.py "
        f"{' '.join(sys.argv[1:])}` ({time.perf_counter() - start:.0f} s, one thread).\n\n{table}\n")
    print(f"wrote {args.out / 'fast_motion.md'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
