"""The race's order of fits (best started first, a band after its start's free fit) and its reserve scene model."""

from __future__ import annotations

import math

import numpy as np

from nct.acquisition.scanner import ImageGrid, Scanner
from nct.fit.conf import LossConf
from nct.method.reconstruct import reconstruct
from nct.scenes.phantoms import CircleConf, ComposedConf, build_phantom
from nct.scenes.simulate import simulate
from nct.select.candidates import SceneModel, candidates
from nct.select.conf import SelectionConf
from nct.select.race import fit_order
from tests.conftest import INIT, MODEL, NO_BACKGROUND, OPTIM, TRAINER, orbit, still


def test_a_band_is_fitted_right_after_its_starts_free_fit():
    """The band's InitFit misfit (lower: a wider band fits FBP frames better) does not put it first: it follows the
    free fit of its start, which sets the bound that stops it early; other candidates keep the best-started order."""
    pool = candidates(SelectionConf(rungs=["rigid", "free"]), 2, span=2.0, scene=SceneModel(1))
    started = dict(zip([c.name for c in pool], [0.5, 0.3, 0.2, 0.1, 0.05, 0.04]))
    assert list(started) == ["rigid", "rigid_start1", "free", "free_start1", "free_band", "free_band_start1"]
    order = fit_order(pool, {c: started[c.name] for c in pool})
    assert [c.name for c in order] == ["free_start1", "free_band_start1", "free", "free_band", "rigid_start1", "rigid"]


def test_an_affine_fit_runs_right_after_its_starts_rigid_fit():
    """Rigid and affine InitFits fit the same template from the same start: the affine fit, the relaxation, follows
    the rigid fit of its start whatever their InitFit misfits; without a rigid candidate it keeps its own place."""
    pool = candidates(SelectionConf(rungs=["static", "rigid", "affine", "free"]), 1, span=1.0, scene=SceneModel(1))
    started = dict(zip([c.name for c in pool], [0.4, 0.3, 0.1, 0.2]))
    assert list(started) == ["static", "rigid", "affine", "free"]
    order = fit_order(pool, {c: started[c.name] for c in pool})
    assert [c.name for c in order] == ["free", "rigid", "affine", "static"]
    alone = [c for c in pool if c.rung != "rigid"]
    assert [c.name for c in fit_order(alone, {c: started[c.name] for c in alone})] == ["affine", "free", "static"]


GRID = ImageGrid(32)


def test_a_winner_worse_than_fbp_races_the_next_scene_model():
    """The next scene model (select/scene.SceneChoice.reserve: here two objects, a faint still disc beside the
    orbiting one, which the judge priced above one) joins the tournament only where the winner explains the
    held-out views worse than motion.fbp_ratio x FBP beyond the noise: at 0 any fit is, at inf none. Its candidates
    carry its label; the first winner's fits are those of a run without it, and where it loses they are not run
    again under its label."""
    scanner = Scanner(views_per_rotation=60, rotations=1.0, rotation_time=0.25, n_bins=32, bin_spacing=1 / 32)
    phantom = build_phantom(ComposedConf(objects=[orbit(0.2, 0.15, 60.0, 1.0), still(-0.25, -0.25, 0.1, 0.1, 0.15)]),
                            scanner.rotation_time)
    times = scanner.frame_times(6)
    sino = simulate(phantom, scanner, GRID, times, None, np.random.default_rng(0))
    raced, alone = (reconstruct(sino, GRID, times, MODEL, LossConf(), TRAINER, 0, logger="none", optim=OPTIM, init=INIT,
                                background=NO_BACKGROUND, motion=SelectionConf(fbp_ratio=ratio))
                    for ratio in (0.0, math.inf))
    assert {(r["n_objects"], r["background"]) for r in alone.selection["table"]} == {(1, "none")}
    assert {(r["n_objects"], r["background"]) for r in raced.selection["table"]} == {(1, "none"), (2, "none")}
    assert all(r["candidate"].startswith("k2_none_") for r in raced.selection["table"] if r["n_objects"] == 2)
    assert raced.selection["winner"] == "k2_none_free"
    assert raced.stages["free_fit"]["misfit_end"] == alone.stages["free_fit"]["misfit_end"]


def test_where_the_next_scene_model_loses_the_first_one_is_not_raced_again():
    """debug=tiny's circle (one disc, 60 views of 32 bins), every fit worse than FBP (fbp_ratio 0): two objects race
    and lose, and the one object's candidates, run under their first names, are not run again under its label."""
    scanner = Scanner(views_per_rotation=60, rotations=1.0, rotation_time=0.25, n_bins=32, bin_spacing=1 / 32)
    times = scanner.frame_times(6)
    sino = simulate(build_phantom(CircleConf(), scanner.rotation_time), scanner, GRID, times, None,
                    np.random.default_rng(0))
    result = reconstruct(sino, GRID, times, MODEL, LossConf(), TRAINER, 0, logger="none", optim=OPTIM, init=INIT,
                         background=NO_BACKGROUND, motion=SelectionConf(fbp_ratio=0.0))
    rows = result.selection["table"]
    assert result.selection["winner"] == "free" and any(r["n_objects"] == 2 for r in rows)
    assert [r["candidate"] for r in rows if r["n_objects"] == 1] == ["free"]
