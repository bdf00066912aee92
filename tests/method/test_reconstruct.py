"""NeuralCT end to end on a tiny moving circle: runs, is seeded, fits, never reads the truth.

NeuralCT along every geometry's rays: the renderer follows the geometry; a tiny fan-beam fit beats FBP.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
import torch

import nct.select.race as race_module
from nct.acquisition.geometry import ParallelGeometry
from nct.acquisition.scanner import ImageGrid, Scanner
from nct.acquisition.sinogram import Sinogram, Truth
from nct.errors import DivergenceError
from nct.fields.conf import ModelConf
from nct.fit.conf import HeldoutConf, LossConf, OptimConf, RenderConf
from nct.fit.problem import heldout_standard_error, rotations_since_start, split_views
from nct.fit.render import project_frames
from nct.init.conf import InitConf
from nct.method.reconstruct import reconstruct
from nct.physics.fbp import fbp_frames
from nct.run.metrics import frame_metrics
from nct.scenes.phantoms import CircleConf, build_phantom
from nct.scenes.signals import EllipseConf, Signal
from nct.scenes.simulate import add_poisson_noise, simulate
from nct.select.conf import SelectionConf
from tests.conftest import (
    GEOMETRIES,
    INIT,
    MODEL,
    NO_BACKGROUND,
    OPTIM,
    TRAINER,
    closed_form_sinogram,
    fit_composed,
    moving_disc,
    still,
)

GRID = ImageGrid(32)


@pytest.fixture(scope="module")
def acquisition():
    return moving_disc(GRID)


def run(sino, times, optim=OPTIM, seed=0, loss=LossConf(), background=NO_BACKGROUND, **kw):
    return reconstruct(sino, GRID, times, MODEL, loss, TRAINER, seed, log_dir=None, logger="none",
                       optim=optim, init=INIT, background=background, **kw)


@pytest.fixture(scope="module")
def fitted(acquisition):
    """The default fit (seed 0), which several tests read: a seeded fit repeats bit for bit
    (test_runs_fits_and_is_seeded runs it again to check)."""
    return run(*acquisition)


def test_runs_fits_and_is_seeded(acquisition, fitted):
    sino, times = acquisition
    result = fitted
    assert result.frames.shape == (6, 32, 32) and result.frames.dtype == np.float32
    assert result.sdf.shape == (6, 1, 32, 32)
    assert result.intensities[0] == pytest.approx(1.0, abs=0.25)  # estimated from the FBP frames
    assert set(result.stages) == {"free_init", "free_fit"} and result.stages["free_fit"]["steps"] == 40
    assert result.model["n_params"] > 0 and result.model["motion"] == "free" and not result.model["static"]
    assert result.model["carried"]  # one object in parallel beam, its mass steady: carried along its path
    assert not result.model["turned"]  # a disc has no axis to turn with
    assert result.selection["winner"] == "free" and [r["verdict"] for r in result.selection["table"]] == ["winner"]
    np.testing.assert_array_equal(run(sino, times).frames, result.frames)
    assert not np.array_equal(run(sino, times, seed=1).frames, result.frames)
    # Fitting the sinogram lowers the misfit on views it never saw.
    unfitted = run(sino, times, replace(OPTIM, fit_steps=0))
    assert result.heldout_loss < 0.8 * unfitted.heldout_loss
    assert 0 < result.heldout_se < 0.5 * result.heldout_loss


def test_a_turning_bar_is_carried_and_turned_with_its_axis():
    """The bar experiment's shape (0.35 x 0.06) turning 100 deg/rotation, 40 px: carried along its path
    and turned with the axis its views' second moments give: Dice 0.95 (carried unturned, 0.67; FBP 0.51)."""
    bar = EllipseConf(a=Signal(0.35), b=Signal(0.06), angle_deg=Signal(rate=100.0), intensity=Signal(1.0))
    sino, times, result = fit_composed([bar], ImageGrid(40), OPTIM)
    assert result.model["carried"] and result.model["turned"]
    level = sino.truth.level
    nct = float(np.median(frame_metrics(result.frames, sino.truth.frames, level).dice))
    fbp = float(np.median(frame_metrics(fbp_frames(sino, ImageGrid(40), times), sino.truth.frames, level).dice))
    assert nct >= 0.9 and fbp < 0.6


def test_one_turning_part_among_still_ones_turns_with_its_axis():
    """A bar (0.25 x 0.1) turning 150 deg/rotation about its own still centre beside a still disc, 40 px:
    the part's axis is read off the views beside the disc's, and the free field turning the bar (the
    brighter object) wins the tournament over turning the disc or neither. Measured: the bar's Dice
    0.94 (the unturned free field's 0.78; FBP 0.69)."""
    bar = EllipseConf(x=Signal(0.1), y=Signal(0.08), a=Signal(0.25), b=Signal(0.1), angle_deg=Signal(rate=150.0),
                      intensity=Signal(1.0))
    sino, times, result = fit_composed([bar, still(-0.2, -0.18, 0.1, 0.1, 0.4)], ImageGrid(40), OPTIM)
    bright = int(np.argmax(result.intensities))
    assert result.selection["winner"] == f"free_turn{bright}" and result.model["turned_object"] == bright
    raced = {row["candidate"] for row in result.selection["table"]}
    assert raced == {"free", "free_start1", "free_turn0", "free_turn1"}
    bar_truth = (sino.truth.frames > 0.7).astype(np.float32)  # the bar alone: 1.0 over the disc's 0.4
    nct = float(np.median(frame_metrics(result.frames, bar_truth, 0.5).dice))
    fbp = float(np.median(frame_metrics(fbp_frames(sino, ImageGrid(40), times), bar_truth, 0.7).dice))
    assert nct >= 0.9 and fbp < 0.75, (nct, fbp)


def test_fit_never_reads_the_truth(acquisition):
    sino, times = acquisition
    fake = Truth(frames=np.random.default_rng(5).random(sino.truth.frames.shape).astype(np.float32),
                 times=sino.truth.times, extent=9.0, level=0.1)
    swapped = Sinogram(sino.values, sino.angles, sino.times, sino.geometry, truth=fake)
    stripped = Sinogram(sino.values, sino.angles, sino.times, sino.geometry, truth=None)
    short = replace(OPTIM, init_steps=10, fit_steps=10)
    base = run(sino, times, short).frames
    np.testing.assert_array_equal(run(swapped, times, short).frames, base)
    np.testing.assert_array_equal(run(stripped, times, short).frames, base)


def test_refinement_adds_the_second_pass(acquisition):
    sino, times = acquisition
    optim = replace(OPTIM, init_steps=5, fit_steps=5, refine_init_steps=5, refine_fit_steps=5)
    first, refined = run(sino, times, optim).stages, run(sino, times, replace(optim, refine=True)).stages
    assert list(refined) == [*first, "refine_init", "refine_fit"]  # 5 steps: the first pass may restart


def test_huge_learning_rate_is_reported_as_divergence(acquisition):
    sino, times = acquisition
    with pytest.raises(DivergenceError, match="stage 'free_init' diverged at step"):
        run(sino, times, replace(OPTIM, lr=1e3, warmup_steps=0))


def test_time_is_measured_in_rotations():
    angles = 0.3 + np.linspace(0, 4 * np.pi, 9)  # two rotations over 1 s, starting at t = 2 s
    sino = Sinogram(np.zeros((9, 4), np.float32), angles, 2.0 + np.linspace(0, 1, 9), ParallelGeometry(4, 0.25))
    clock = rotations_since_start(sino)
    torch.testing.assert_close(clock(np.array([2.0, 2.5, 3.0])), torch.tensor([0.0, 1.0, 2.0]))
    with pytest.raises(ValueError, match="positive time"):
        rotations_since_start(Sinogram(np.zeros((2, 4), np.float32), np.zeros(2), np.zeros(2), sino.geometry))


def test_every_tenth_view_is_held_out():
    fit, held = split_views(30, 10)
    np.testing.assert_array_equal(held, [5, 15, 25])
    assert len(fit) == 27 and not set(fit) & set(held)
    assert len(split_views(30, 0)[1]) == 0
    fit, held = split_views(40, 4, run=3)  # blocks of time: every 4th run of 3 consecutive views
    np.testing.assert_array_equal(held, [6, 7, 8, 18, 19, 20, 30, 31, 32])
    assert len(fit) == 31 and not set(fit) & set(held)


def test_bad_arguments(acquisition):
    sino, times = acquisition
    with pytest.raises(ValueError, match="n_objects"):
        run(sino, times, n_objects=0)
    with pytest.raises(ValueError, match="logger"):
        reconstruct(sino, GRID, times, MODEL, LossConf(), TRAINER, 0, None, logger="wandb", background=NO_BACKGROUND)
    with pytest.raises(ValueError, match="render.band_start_px must be >= render.band_px"):
        RenderConf(band_px=2.0, band_start_px=1.0)
    with pytest.raises(ValueError, match="loss.tv_time"):
        LossConf(tv_time=-1.0)


def test_heldout_views_are_scored_as_validation(acquisition):
    """val/heldout_loss is Lightning's validation of the held-out views: after the last step it
    equals the held-out score the result reports."""
    sino, times = acquisition
    result = run(sino, times, heldout=HeldoutConf(every=10, check_every=OPTIM.fit_steps // 2))
    assert result.stages["free_fit"]["losses"]["val/heldout_loss"] == pytest.approx(result.heldout_loss, rel=1e-5)
    off = run(sino, times, heldout=HeldoutConf(every=10, check_every=0))
    assert "val/heldout_loss" not in off.stages["free_fit"]["losses"]
    np.testing.assert_array_equal(off.frames, result.frames)  # scoring never changes the fit


def test_coarse_lattice_fits_as_well(acquisition, fitted):
    """The first pass on a lattice half the image's side explains the held-out views about as well,
    summed over seeds 0-2 (one seed's ratio ranges 1.0-1.5 with the seed and the thread count)."""
    sino, times = acquisition
    full = [fitted] + [run(sino, times, seed=s) for s in (1, 2)]
    coarse = [run(sino, times, replace(OPTIM, coarse_size=16), seed=s) for s in range(3)]
    assert not np.array_equal(coarse[0].frames, full[0].frames)
    assert sum(r.heldout_loss for r in coarse) < 1.3 * sum(r.heldout_loss for r in full)


def test_poisson_data_term_is_l1_on_noiseless_data_and_fits_noisy_data(acquisition, fitted):
    sino, times = acquisition
    poisson = LossConf(data_term="poisson")
    np.testing.assert_array_equal(run(sino, times, loss=poisson).frames, fitted.frames)
    noisy = replace(sino, values=add_poisson_noise(sino.values, 1e3, 1.0, np.random.default_rng(0)), i0=1e3)
    l1, weighted = run(noisy, times), run(noisy, times, loss=poisson)
    assert not np.array_equal(weighted.frames, l1.frames)
    assert weighted.heldout_loss == pytest.approx(l1.heldout_loss, rel=0.1)


def test_a_fit_that_loses_its_way_enters_a_restart_at_half_the_rates(acquisition):
    """An intensity rate of 3.5 throws a(k) off (misfit 0.56 from 0.094); a restart of the same
    candidate from its InitFit at half the rates joins the tournament, does not lose its way, and wins."""
    sino, times = acquisition
    result = run(sino, times, replace(OPTIM, intensity_lr=3.5))
    fits = {k: v for k, v in result.stages.items() if k.endswith("_fit")}
    assert list(fits) == ["free_fit", "free_restart_fit"]
    assert fits["free_fit"]["misfit_end"] > 1.5 * fits["free_fit"]["misfit_start"]
    assert fits["free_restart_fit"]["misfit_start"] == fits["free_fit"]["misfit_start"]  # the same InitFit
    assert fits["free_restart_fit"]["misfit_end"] < fits["free_restart_fit"]["misfit_start"]  # measured 0.074 from 0.094
    assert result.selection["winner"] == "free_restart"
    assert result.heldout_loss == pytest.approx(fits["free_restart_fit"]["misfit_end"], rel=1e-5)


def test_a_candidate_whose_fit_diverges_drops_out_and_the_tournament_goes_on(acquisition, monkeypatch):
    """Seen on a GPU: a band candidate diverged at step 100 after the free field had finished, and the
    whole run failed. Now it drops out, its restart joins at half the rates, and the rest is unchanged."""
    sino, times = acquisition
    ladder = SelectionConf(rungs=["static", "free"], still_ratio=0.0)
    honest = race_module.sinogram_fit

    def static_diverges(prob, session, net, name, *args, **kwargs):
        if name == "static":
            raise DivergenceError("stage 'static_fit' diverged at step 3: loss nan")
        return honest(prob, session, net, name, *args, **kwargs)

    monkeypatch.setattr(race_module, "sinogram_fit", static_diverges)
    result = run(sino, times, motion=ladder)
    table = {r["candidate"]: r for r in result.selection["table"]}
    assert table["static"]["verdict"].startswith("diverged: stage 'static_fit'") and table["static"]["steps"] == 0
    assert "static_restart" in table and result.selection["winner"] == "free"
    assert result.stages["static_fit"]["verdict"].startswith("diverged")
    alone = run(sino, times)
    assert result.stages["free_fit"]["misfit_end"] == alone.stages["free_fit"]["misfit_end"]


def test_the_run_fails_with_the_divergence_when_no_candidate_finishes(acquisition, monkeypatch):
    def diverges(prob, session, net, name, *args, **kwargs):
        raise DivergenceError(f"stage '{name}_fit' diverged at step 3: loss nan")

    monkeypatch.setattr(race_module, "sinogram_fit", diverges)
    with pytest.raises(DivergenceError, match="stage 'free_fit' diverged"):
        run(*acquisition)


def test_the_ladder_chooses_static_for_a_still_scene_and_free_for_a_moving_one(acquisition):
    """motion.rungs [static, free]: a still disc is explained as well by a shape (the simpler wins
    within tolerance; seeds 0-3 all chose static, free's held-out misfit lower by 7-11 % on three of
    them); the moving one is not. Each candidate's fit is the same as when run alone."""
    sino, times = acquisition
    ladder = SelectionConf(rungs=["static", "free"])
    moving = run(sino, times, motion=ladder)
    table = {r["candidate"]: r for r in moving.selection["table"]}
    assert moving.selection["winner"] == "free" and {"static", "free"} <= set(table)  # a static_restart may join
    assert table["static"]["heldout_misfit"] > (1 + ladder.tolerance) * table["free"]["heldout_misfit"] or \
        table["static"]["steps"] < OPTIM.fit_steps
    alone = run(sino, times)
    assert moving.stages["free_fit"]["misfit_end"] == alone.stages["free_fit"]["misfit_end"]
    still = replace(sino, values=_still_views())
    chosen = run(still, times, motion=replace(ladder, still_ratio=0.0))  # both fitted: the held-out views choose
    assert chosen.selection["winner"] == "static" and chosen.model["motion"] == "static"
    assert "free_fit" in chosen.stages


def test_a_still_scan_fits_the_static_rung_alone_and_lists_the_rest(acquisition):
    """Where the views' conjugates agree (select/stillness.py) the moving rungs are not fitted; selection.csv says
    so; the static fit is the one the whole ladder runs."""
    sino, times = acquisition
    still = replace(sino, values=_still_views())
    ladder = SelectionConf(rungs=["static", "free"])
    result = run(still, times, motion=ladder)
    table = {r["candidate"]: r for r in result.selection["table"]}
    assert result.selection["winner"] == "static" and "free_fit" not in result.stages
    assert table["free"]["steps"] == 0 and table["free"]["verdict"].startswith("not fitted: the views' conjugate")
    whole = run(still, times, motion=replace(ladder, still_ratio=0.0))
    assert result.stages["static_fit"]["misfit_end"] == whole.stages["static_fit"]["misfit_end"]


def _still_views() -> np.ndarray:
    """The views of moving_disc's acquisition (tests/conftest.py) of the same disc held still, analytically."""
    phantom = build_phantom(CircleConf(radius=0.2, orbit_radius=0.15, displacement_deg=0.0), 0.25)
    scanner = Scanner(views_per_rotation=60, rotations=1.0, rotation_time=0.25, n_bins=32, bin_spacing=1 / 32)
    return phantom.project(scanner, GRID)


def test_heldout_standard_error_comes_from_blocks_of_neighbouring_views():
    rng = np.random.default_rng(0)
    independent = rng.normal(1.0, 0.1, 1000)
    assert heldout_standard_error(independent) == pytest.approx(0.1 / np.sqrt(1000), rel=0.35)
    drifting = np.linspace(0.9, 1.1, 1000)  # misfits that follow the motion: neighbours alike
    assert heldout_standard_error(drifting) > 5 * drifting.std() / np.sqrt(1000)
    assert np.isnan(heldout_standard_error(np.ones(1)))


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


@pytest.mark.parametrize("shape, offset", [("curved", 0.0), ("flat", 0.132)],
                         ids=["curved", "flat-offset"])  # a flat detector centred: the offset one with u shifted
def test_small_fan_beam_fit_of_the_circle_experiment_beats_fbp_by_the_issue_margin(shape, offset):
    """Issue 11's bar at a small size: the circle experiment (100 deg/rotation) in fan beam, NCT
    Dice >= 0.93 and >= fan-beam FBP + 0.08, its one object given (the geometry is tested here, not the
    choice of K: 8 s a geometry instead of 22). Measured (64^2, 180 views, 300 steps, session 59): NCT
    0.938 curved, 0.946 flat-offset (K chosen: 0.941, 0.946), FBP 0.831, 0.834; at full size
    (benchmarks/results/fan) 0.964-0.966 vs 0.823-0.826."""
    scanner = Scanner(180, 1.0, 0.25, n_bins=64, bin_spacing=2.2 / 64, source_distance=2.0, detector_distance=2.0,
                      detector_shape=shape, detector_offset=offset)
    phantom = build_phantom(CircleConf(radius=0.15, orbit_radius=0.2, displacement_deg=100.0), scanner.rotation_time)
    times, grid = scanner.frame_times(12), ImageGrid(64)
    sino = simulate(phantom, scanner, grid, times, None, np.random.default_rng(0))
    model = ModelConf(width=32, depth=2, temporal_width=32, temporal_depth=2, n_terms=16)
    optim = OptimConf(init_steps=100, fit_steps=300, refine=False, batch_views=10, warmup_steps=10, lr_decay_every=30)
    result = reconstruct(sino, grid, times, model, LossConf(), TRAINER, 0, log_dir=None, logger="none", optim=optim,
                         init=InitConf(frames_per_rotation=24), background=NO_BACKGROUND, n_objects=1)
    level = sino.truth.level
    nct = float(np.median(frame_metrics(result.frames, sino.truth.frames, level).dice))
    fbp = float(np.median(frame_metrics(fbp_frames(sino, grid, times), sino.truth.frames, level).dice))
    assert nct >= 0.93 and nct >= fbp + 0.08
