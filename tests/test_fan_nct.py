"""NeuralCT along every geometry's rays: the renderer follows the geometry; a tiny fan-beam fit beats FBP."""

from __future__ import annotations

import numpy as np
import pytest
import torch
from geometry_cases import GEOMETRIES, closed_form_sinogram

from nct.method.fields import ModelConf
from nct.method.reconstruct import reconstruct
from nct.run.metrics import frame_metrics
from nct.scenes.phantoms import CircleConf, build_phantom
from nct.physics.projector import fbp_frames
from nct.method.render import project_frames
from nct.acquisition.scanner import ImageGrid, Scanner
from nct.scenes.simulate import simulate
from nct.method.conf import InitConf, LossConf, OptimConf, TrainerConf

ANGLES = np.array([0.0, 0.7, 1.9, 3.0])
DISC = (0.08, -0.05, 0.2, 0.2, 0.0, 1.0)


@pytest.mark.parametrize("geometry", GEOMETRIES.values(), ids=GEOMETRIES.keys())
@pytest.mark.parametrize("k_samp", [1, 2])
def test_rendered_disc_matches_closed_form_chords(geometry, k_samp):
    grid = ImageGrid(64)
    x, y = grid.xy()
    sdf = torch.from_numpy(0.2 - np.hypot(x - DISC[0], y - DISC[1])).float()
    sdf = sdf[None, None].expand(len(ANGLES), 1, -1, -1)
    sino = project_frames(sdf, torch.ones(1), torch.tensor(ANGLES), geometry, 1.0, grid.pixel_size, 50.0, k_samp)
    expected = closed_form_sinogram(geometry, ANGLES, [DISC], sub_rays=k_samp)
    # As test_render.py's parallel-beam check: mean error relative to the mean (edge rays sample the ramp).
    # Measured: 0.86-1.04 % with one ray a bin, 0.47-0.54 % with two.
    assert np.abs(sino.numpy() - expected).mean() / expected.mean() < {1: 0.012, 2: 0.007}[k_samp]


@pytest.mark.parametrize("shape, offset", [("flat", 0.0), ("curved", 0.0), ("flat", 0.132)],
                         ids=["flat", "curved", "flat-offset"])
def test_small_fan_beam_fit_of_the_circle_experiment_beats_fbp_by_the_issue_margin(shape, offset):
    """Issue 11's bar at a small size: the circle experiment (100 deg/rotation) in fan beam, NCT
    Dice >= 0.93 and >= fan-beam FBP + 0.08. Measured (64^2, 180 views, 300 steps): NCT
    0.946-0.948, FBP 0.831-0.835; at full size (benchmarks/results/fan) 0.964-0.966 vs 0.823-0.826."""
    scanner = Scanner(180, 1.0, 0.25, n_bins=64, bin_spacing=2.2 / 64, source_distance=2.0, detector_distance=2.0,
                      detector_shape=shape, detector_offset=offset)
    phantom = build_phantom(CircleConf(radius=0.15, orbit_radius=0.2, displacement_deg=100.0), scanner.rotation_time)
    times, grid = scanner.frame_times(12), ImageGrid(64)
    sino = simulate(phantom, scanner, grid, times, None, np.random.default_rng(0))
    model = ModelConf(width=32, depth=2, temporal_width=32, temporal_depth=2, n_terms=16)
    optim = OptimConf(init_steps=100, fit_steps=300, refine=False, batch_views=10, warmup_steps=10, lr_decay_every=30)
    result = reconstruct(sino, grid, times, model, LossConf(), TrainerConf(accelerator="cpu", progress_bar=False), 0,
                         log_dir=None, logger="none", optim=optim, init=InitConf(frames_per_rotation=24))
    level = sino.truth.level
    nct = float(np.median(frame_metrics(result.frames, sino.truth.frames, level).dice))
    fbp = float(np.median(frame_metrics(fbp_frames(sino, grid, times), sino.truth.frames, level).dice))
    assert nct >= 0.93 and nct >= fbp + 0.08
