"""nct from Python, cell by cell: a sinogram made in memory, reconstructed, looked at, re-rendered, saved, loaded.

Run it as a script (``python docs/examples/reconstruct.py``, about half a minute on one core) or cell by
cell (``# %%``) in an editor or Jupyter. The fits are kept short so that it runs in seconds (and in the
tests, tests/test_api.py); drop ``optim=...`` for the default fit. docs/API.md describes each call.
"""

# %% A sinogram in memory: a disc of intensity 1 orbiting the centre, 100 degrees per gantry rotation,
# parallel beam, its line integrals in closed form (2 sqrt(r^2 - d^2) at distance d from its centre).
import tempfile
from pathlib import Path

import numpy as np

import nct

views, bins, rotation_time = 90, 48, 0.25  # views of one rotation, detector bins, seconds per rotation
angles = np.linspace(0, 2 * np.pi, views, endpoint=False)  # radians
times = angles / (2 * np.pi) * rotation_time  # seconds: the gantry turns once
u = (np.arange(bins) - (bins - 1) / 2) / bins  # bin centres on a detector as wide as the field of view (1)


def centre(t: np.ndarray) -> np.ndarray:
    """The disc's centre at times t [T] (s): [T, 2], 0.2 from the image centre, 100 degrees a rotation."""
    phase = np.deg2rad(100) * t / rotation_time
    return 0.2 * np.stack([np.cos(phase), np.sin(phase)], axis=-1)


radius = 0.15
s = centre(times) @ np.stack([np.cos(angles), np.sin(angles)])  # [V, V]: every centre on every view's axis
along = np.diagonal(s)[:, None]  # each view sees the disc where it is at its own time: [V, 1]
sinogram = 2 * np.sqrt(np.clip(radius**2 - (u[None, :] - along) ** 2, 0, None))  # [V, B], float64 is fine

# %% The scan: the arrays, checked as a sinogram file is (a bad shape is one line naming the argument),
# and the frames to reconstruct: 48 pixels a side over the field of view, 6 a rotation.
scan = nct.Scan(sinogram, angles, times, bin_spacing=1 / bins, size=48, extent=1.0, frames_per_rotation=6)
print(scan)

# %% Reconstruct: FBP, and NeuralCT with K = 1 object on an empty background (None: both chosen from
# the data), seed 0; settings are the `nct` command's config groups, as dicts of keys or option names.
rec = nct.reconstruct(scan, n_objects=1, background="none", seed=0, threads=1,
                      optim={"init_steps": 40, "fit_steps": 80})

# %% What came out: frames [F, H, W] at times [F] (s), each object's mask [F, K, H, W], the candidates the
# tournament fitted on the held-out views (typed rows, as selection.csv) and the truth-free warnings.
print("frames", rec.frames.shape, "masks", rec.masks.shape, "at", np.round(rec.times, 3), "s")
for row in rec.selection:
    print(f"  {row.candidate}: held-out misfit {row.heldout_misfit:.4f}, {row.verdict}")
print("warnings:", rec.warnings or "none")

# %% Scores against the known disc: a truth on the frames' grid at their times (nct.Truth), Dice at level 0.5.
x, y = rec.scan.grid.xy()  # each pixel centre's coordinates [H, W] (y up, row 0 at the top)
inside = [(x - cx) ** 2 + (y - cy) ** 2 <= radius**2 for cx, cy in centre(rec.times)]
truth = nct.Truth(frames=np.asarray(inside, dtype=np.float32), times=rec.times, extent=1.0, level=0.5)
scores = rec.metrics(truth)
print(f"median Dice: FBP {np.median(scores['fbp'].dice):.3f}, NeuralCT {np.median(scores['nct'].dice):.3f}")

# %% The fitted field is continuous in space and time: render it at other times and a finer grid.
fine_times = np.linspace(rec.times[0], rec.times[-1], 12)
frames, sdf = rec.render(fine_times, size=96)  # [12, 96, 96] intensity, [12, K, 96, 96] signed distance
print("rendered", frames.shape, "sdf", sdf.shape)

# %% Save and load: the folder holds the files of a run folder; loading gives equal arrays and the field.
with tempfile.TemporaryDirectory() as tmp:
    folder = rec.save(Path(tmp) / "disc")
    again = nct.load(folder)
    assert np.array_equal(again.frames, rec.frames) and np.array_equal(again.masks, rec.masks)
    assert np.array_equal(again.render(fine_times, size=96)[0], frames)
    print("saved and loaded:", sorted(p.name for p in folder.iterdir()))
