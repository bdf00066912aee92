"""The race's order of fits: best started first, a band after its start's free fit."""

from __future__ import annotations

from nct.select.candidates import SceneModel, candidates
from nct.select.conf import SelectionConf
from nct.select.race import fit_order


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
