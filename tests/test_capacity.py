"""Capacity from held-out views: the rule on hand-made numbers, and a static scene ending with a
static model while a moving one gets temporal terms (small grid-family fits, ~10 s each); the
per-object motion measure that makes an object static."""

from __future__ import annotations

import numpy as np
import pytest

from nct.method.capacity import CapacityConf, Rung, boundary_motion_px, climb, explain, next_rung_pays, object_models
from nct.method.fields import ModelConf
from nct.method.reconstruct import reconstruct
from nct.run.metrics import frame_metrics
from nct.scenes.phantoms import CircleConf, StaticConf, build_phantom
from nct.acquisition.scanner import ImageGrid, Scanner
from nct.scenes.simulate import simulate
from nct.method.conf import LossConf, OptimConf, TrainerConf

GRID = ImageGrid(32)
MODEL = ModelConf(family="grid", resolution=32, temporal_resolution=16, levels=3)
TRAINER = TrainerConf(accelerator="cpu", progress_bar=False)
OPTIM = OptimConf(init_steps=100, fit_steps=200, refine=False)
AUTO = CapacityConf(name="auto", auto=True, ladder=[0, 8, 32], tolerance=0.05)


def test_rule_on_hand_made_numbers():
    static, small, big = Rung(0, 0.40, 100), Rung(8, 0.025, 200), Rung(32, 0.024, 500)
    assert next_rung_pays(static, small, 0.05) and not next_rung_pays(small, big, 0.05)
    assert next_rung_pays(small, big, 0.0)
    assert explain([static, small, big], small, 0.05).startswith("8 temporal terms: 32 terms changed the held-out "
                                                                 "loss by -4.0%")
    assert explain([static, small], static, 0.05).startswith("a static model: 8 terms")
    assert "top of the ladder" in explain([static, small], small, 0.05)


def test_climb_stops_at_the_first_rung_that_does_not_pay():
    losses = {0: 0.40, 8: 0.025, 32: 0.024, 64: 0.001}
    fitted = []

    def fit(m):
        fitted.append(m)
        return Rung(m, losses[m], m)

    tried, chosen = climb([0, 8, 32, 64], fit, 0.05)
    assert fitted == [0, 8, 32] and chosen.n_terms == 8 and [r.n_terms for r in tried] == fitted
    assert climb([0, 8], fit, 0.05)[1].n_terms == 8  # every rung paid: the top
    assert climb([32], fit, 0.05)[1].n_terms == 32  # capacity fixed: one rung


@pytest.mark.parametrize("kwargs, message", [
    (dict(ladder=[]), "capacity.ladder must be a non-empty list"),
    (dict(ladder=[0, 8, 8]), "capacity.ladder must be strictly increasing"),
    (dict(ladder=[-1, 8]), "capacity.ladder must be term counts >= 0"),
    (dict(tolerance=1.5), "capacity.tolerance must be in \\[0, 1\\)"),
    (dict(static_below_px=-1.0), "capacity.static_below_px must be >= 0"),
    (dict(band_f_max=0.0), "capacity.band_f_max must be > 0 or null"),
    (dict(band_gain=0.0), "capacity.band_gain must be in \\(0, 1\\]"),
    (dict(band_gain=1.5), "capacity.band_gain must be in \\(0, 1\\]"),
    (dict(band_min_rotations=-1.0), "capacity.band_min_rotations must be >= 0"),
    (dict(band_race_at=1.0), "capacity.band_race_at must be in \\(0, 1\\) or null"),
    (dict(band_race_gain=0.0), "capacity.band_race_gain must be > 0"),
])
def test_bad_settings_are_named(kwargs, message):
    with pytest.raises(ValueError, match=message):
        CapacityConf(**kwargs)


def choose(phantom_conf, seed: int = 0, capacity: CapacityConf = AUTO):
    scanner = Scanner(views_per_rotation=120, rotations=1.0, rotation_time=0.25, n_bins=32, bin_spacing=1 / 32)
    phantom = build_phantom(phantom_conf, scanner.rotation_time)
    times = scanner.frame_times(6)
    sino = simulate(phantom, scanner, GRID, times, None, np.random.default_rng(seed))
    n_objects = len(phantom.intensities)
    result = reconstruct(sino, GRID, times, MODEL, LossConf(), TRAINER, seed, log_dir=None, logger="none",
                         n_objects=n_objects, capacity=capacity, optim=OPTIM)
    return result, float(np.median(frame_metrics(result.frames, sino.truth.frames, sino.truth.level).dice))


def test_static_scene_gets_a_static_model():
    result, dice = choose(StaticConf())
    assert result.capacity["n_terms"] == 0 and result.capacity["static"]
    ladder = result.capacity["choice"]["ladder"]
    assert [r["n_terms"] for r in ladder] == [0, 8]  # stopped as soon as 8 terms did not pay
    assert ladder[1]["heldout_loss"] > 0.95 * ladder[0]["heldout_loss"]
    assert result.capacity["choice"]["reason"].startswith("a static model")
    assert dice > 0.97


def test_moving_scene_gets_temporal_terms():
    result, dice = choose(CircleConf(displacement_deg=100.0))
    ladder = result.capacity["choice"]["ladder"]
    assert result.capacity["n_terms"] > 0
    assert ladder[1]["heldout_loss"] < 0.5 * ladder[0]["heldout_loss"]  # static cannot explain the motion
    assert set(result.stages) >= {"m0_init", "m0_fit", "m8_init", "m8_fit"}
    assert dice > 0.85


def test_static_switch_holds_static_objects_static_and_moving_ones_temporal():
    """capacity.static_below_px=0.25 (fixed terms): the static experiment's objects end static, the
    moving circle keeps its temporal terms; both reconstruct well."""
    switch = CapacityConf(static_below_px=0.25)
    still, dice_still = choose(StaticConf(), capacity=switch)
    objects = still.capacity["objects"]["per_object"]
    assert [o["model"] for o in objects] == ["static"] * len(objects) and len(objects) == 2
    assert max(o["motion_px"] for o in objects) < 0.25 and still.capacity["static"]
    moving, dice_moving = choose(CircleConf(displacement_deg=100.0), capacity=switch)
    assert [o["model"] for o in moving.capacity["objects"]["per_object"]] == ["temporal"]
    assert not moving.capacity["static"] and dice_still > 0.97 and dice_moving > 0.85


def discs(centres_x: list[float], radii: list[float], size: int = 96) -> np.ndarray:
    """One disc per frame (centre x in pixels from the image centre, radius in pixels): [F, H, W] bool."""
    y, x = np.mgrid[:size, :size] + 0.5 - size / 2
    return np.stack([np.hypot(x - cx, y) <= r for cx, r in zip(centres_x, radii)])


def test_boundary_motion_is_the_mean_normal_displacement_in_pixels():
    # A disc shifted by d moves its boundary by d |cos phi|, 2d/pi on average; a disc growing by d by d.
    still = discs([0.0] * 5, [20.0] * 5)
    shifted = discs([-3.0, 0.0, 0.0, 0.0, 3.0], [20.0] * 5)
    growing = discs([0.0] * 5, [20.0, 20.0, 21.0, 22.0, 24.0])
    empty = np.zeros_like(still)
    motion = boundary_motion_px(np.stack([still, shifted, growing, empty], axis=1))
    assert motion[0] == 0.0 and motion[3] == 0.0
    assert motion[1] == pytest.approx(2 / 5 * 3 * 2 / np.pi, rel=0.06)
    assert motion[2] == pytest.approx((1 + 1 + 0 + 1 + 3) / 5, rel=0.06)  # against the majority: radius 21
    assert [o["model"] for o in object_models(motion, 0.25)] == ["static", "temporal", "temporal", "static"]
    with pytest.raises(ValueError, match="masks must be"):
        boundary_motion_px(still)
