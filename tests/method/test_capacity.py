"""Capacity from held-out views: the rule on hand-made numbers, and a static scene ending with a
static model while a moving one gets temporal terms (small grid-family fits, ~10 s each); the
per-object motion measure that makes an object static.

The temporal band (``capacity.band_f_max``): on scans of several rotations a wider band is
fitted too and kept only where the held-out views demand it (benchmarks/results/generalisation:
ellipses turning at about 180 deg/rotation over 3-4 rotations).
"""

from __future__ import annotations

import csv
import json
from dataclasses import replace

import numpy as np
import pytest

from nct.acquisition.io import save_sinogram
from nct.acquisition.scanner import ImageGrid, Scanner
from nct.method.capacity import (
    CapacityConf,
    Rung,
    boundary_motion_px,
    climb,
    explain,
    next_rung_pays,
    object_models,
)
from nct.method.conf import HeldoutConf, LossConf, OptimConf
from nct.method.fields import ModelConf
from nct.method.reconstruct import reconstruct
from nct.run.metrics import frame_metrics
from nct.scenes.phantoms import (
    CircleConf,
    ComposedConf,
    EllipseConf,
    Signal,
    StaticConf,
    build_phantom,
)
from nct.scenes.simulate import simulate
from tests.conftest import INIT, TRAINER
from tests.conftest import MODEL as TINY_MODEL
from tests.conftest import OPTIM as TINY_OPTIM

GRID = ImageGrid(32)
MODEL = ModelConf(family="grid", resolution=32, temporal_resolution=16, levels=3)
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


LONGER = replace(TINY_OPTIM, fit_steps=200, lr_decay_every=66)
OFF = CapacityConf(band_f_max=None)


def turning_ellipse(deg_per_rotation: float, rotations: float):
    """An ellipse (semi-axes 0.25, 0.1) turning about the centre, 60 views per rotation, noiseless:
    (sinogram, 12 frame times)."""
    ellipse = EllipseConf(a=Signal(0.25), b=Signal(0.1), angle_deg=Signal(rate=deg_per_rotation))
    scanner = Scanner(views_per_rotation=60, rotations=rotations, rotation_time=0.25, n_bins=40, bin_spacing=1 / 40)
    times = scanner.frame_times(12)
    phantom = build_phantom(ComposedConf(objects=[ellipse]), scanner.rotation_time)
    return simulate(phantom, scanner, GRID, times, None, np.random.default_rng(0)), times


def run(sino, times, capacity: CapacityConf, f_max: float = TINY_MODEL.f_max, optim=LONGER, heldout=None):
    return reconstruct(sino, GRID, times, replace(TINY_MODEL, f_max=f_max), LossConf(), TRAINER, 0, log_dir=None,
                       logger="none", optim=optim, init=INIT, capacity=capacity, heldout=heldout)


def mse(result, sino) -> float:
    return float(np.mean((result.frames - sino.truth.frames) ** 2))


def test_a_fast_turn_over_three_rotations_keeps_the_wider_band_and_is_that_run():
    sino, times = turning_ellipse(180.0, 3.0)
    often = HeldoutConf(check_every=40)  # the race at 0.6 x 200 = 120 and 160 (checks at 40, 80, ..., 200)
    banded, narrow = run(sino, times, CapacityConf(), heldout=often), run(sino, times, OFF, heldout=often)
    band = banded.capacity["band"]
    assert band["f_max"] == [0.3, 0.5] and band["kept_f_max"] == 0.5 and banded.capacity["f_max"] == 0.5
    # The configured band cannot follow one cycle per rotation: its held-out loss is far above.
    assert band["heldout_loss"][1] < 0.5 * band["heldout_loss"][0]
    assert band["heldout_loss"][0] == pytest.approx(narrow.heldout_loss, rel=1e-6)
    assert list(banded.stages) == ["init", "fit", "band_init", "band_fit"]
    assert band["race"]["step"] == 160 and not band["race"]["lost"]  # ahead at 120 and 160: fitted on
    assert banded.stages["band_fit"]["steps"] == LONGER.fit_steps
    assert mse(banded, sino) < 0.5 * mse(narrow, sino), (mse(banded, sino), mse(narrow, sino))
    # The kept band is the run configured at that band, bit for bit (same random streams).
    wide = run(sino, times, OFF, f_max=0.5, heldout=often)
    np.testing.assert_array_equal(banded.frames, wide.frames)
    assert banded.heldout_loss == wide.heldout_loss


def test_a_slow_turn_keeps_the_configured_band_unchanged():
    sino, times = turning_ellipse(30.0, 2.0)
    banded, narrow = run(sino, times, CapacityConf(), optim=TINY_OPTIM), run(sino, times, OFF, optim=TINY_OPTIM)
    band = banded.capacity["band"]
    assert band["kept_f_max"] == 0.3 and band["heldout_loss"][1] > 0.6 * band["heldout_loss"][0]
    assert band["race"] is None  # one held-out check, at the last step: nothing to race on
    np.testing.assert_array_equal(banded.frames, narrow.frames)
    assert banded.heldout_loss == narrow.heldout_loss


def test_a_wider_band_that_falls_behind_stops_at_the_race_and_changes_nothing():
    sino, times = turning_ellipse(30.0, 2.0)
    often = HeldoutConf(check_every=10)  # checks at steps 10, 20, 30, 40: the race runs from 0.6 x 40 = 24, so at 30
    # A strict gain makes the stop certain on so short a fit; the rule's own numbers are tested below.
    banded, narrow = run(sino, times, CapacityConf(band_race_gain=0.5), optim=TINY_OPTIM, heldout=often), \
        run(sino, times, OFF, optim=TINY_OPTIM, heldout=often)
    race = banded.capacity["band"]["race"]
    assert race["step"] == 30 and race["lost"] and race["heldout_loss"][1] > 0.5 * race["heldout_loss"][0]
    assert banded.stages["band_fit"]["steps"] == 30 and banded.stages["fit"]["steps"] == 40
    assert [s for s, _ in banded.stages["band_fit"]["heldout_history"]] == [10, 20, 30]
    assert "stopped at step 30" in banded.capacity["band"]["reason"]
    np.testing.assert_array_equal(banded.frames, narrow.frames)
    assert banded.heldout_loss == narrow.heldout_loss


def test_the_race_stops_the_wider_fit_at_the_first_check_where_it_falls_behind():
    conf = CapacityConf(band_race_at=0.3, band_race_gain=0.9)
    ours = [(100, 0.5), (200, 0.2), (300, 0.1), (400, 0.1), (500, 0.1), (1000, 0.05)]
    assert conf.band_race([(200, 0.4), (300, 0.05), (400, 0.091), (500, 0.2)], ours, 1000) == {
        "step": 400, "heldout_loss": [0.1, 0.091], "gain": 0.9, "lost": True}  # before 300 it does not count
    assert conf.band_race([(300, 0.05), (400, 0.09)], ours, 1000) == {
        "step": 400, "heldout_loss": [0.1, 0.09], "gain": 0.9, "lost": False}  # ahead at every check so far
    assert conf.band_race([(200, 0.4)], ours, 1000) is None  # not yet due
    assert conf.band_race([(1000, 0.4)], ours, 1000) is None  # the last step: the fit is over anyway
    assert CapacityConf(band_race_at=None).band_race([(400, 0.5)], ours, 1000) is None


@pytest.mark.parametrize("f_max, rotations, n_terms, held_out, tried", [
    (0.3, 3.0, 32, True, True),
    (0.3, 1.0, 32, True, False),   # one rotation: each angle is seen once
    (0.3, 1.5, 32, True, True),
    (0.5, 3.0, 32, True, False),   # already at the wider band
    (3.0, 3.0, 32, True, False),   # the paper's band is wider
    (0.3, 3.0, 0, True, False),    # a static model has no band
    (0.3, 3.0, 32, False, False),  # nothing to score it on
])
def test_when_the_band_is_tried(f_max, rotations, n_terms, held_out, tried):
    assert CapacityConf().tries_band(f_max, rotations, n_terms, held_out) is tried
    assert not OFF.tries_band(f_max, rotations, n_terms, held_out)


def test_the_band_is_kept_only_for_a_large_gain():
    conf = CapacityConf(band_gain=0.6)
    assert conf.keeps_band(0.1, 0.06) and not conf.keeps_band(0.1, 0.061)


def fake_call(root, rows: dict[str, tuple[int, float]]):
    """A generalisation call's folder: scenes.csv, and per scene the run's sinogram file and
    metrics.json (rotations, held-out loss)."""
    root.mkdir()
    (root / "scenes.csv").write_text("\n".join(["scene", *rows]) + "\n")
    for scene, (rotations, loss) in rows.items():
        run = root / "runs" / scene / "nct"
        run.mkdir(parents=True)
        save_sinogram(run / "sinogram.npz", turning_ellipse(30.0, rotations)[0])
        (run / "metrics.json").write_text(json.dumps({"heldout_loss": loss}))
    return root


def test_band_choices_copies_each_scene_from_the_run_the_rule_keeps(tmp_path):
    from tests.conftest import load_benchmark as load
    narrow = fake_call(tmp_path / "narrow", {"a": (1, 0.1), "b": (3, 0.1), "c": (2, 0.1)})
    wide = fake_call(tmp_path / "wide", {"a": (1, 0.01), "b": (3, 0.05), "c": (2, 0.07)})
    args = ["--narrow", str(narrow), "--wide", str(wide), "--out", str(tmp_path / "o")]
    assert load("diagnostics/band_choices").main(args) == 0
    copied = {s: json.loads((tmp_path / "o" / "runs" / s / "nct" / "metrics.json").read_text())["heldout_loss"]
              for s in "abc"}
    assert copied == {"a": 0.1, "b": 0.05, "c": 0.1}  # a: one rotation, never tried; c: 0.7 > 0.6
    rows = list(csv.reader((tmp_path / "o" / "band_choices.csv").open()))
    assert [r[0] for r in rows[1:]] == ["b", "c"] and [r[4] for r in rows[1:]] == ["True", "False"]


def test_band_race_replays_the_rule_on_recorded_histories(tmp_path, capsys):
    from tests.conftest import load_benchmark as load

    def run(scene: str, wide: list[float], kept: bool) -> None:
        steps = [100 * (i + 1) for i in range(10)]
        stages = {"fit": {"kept": True, "steps": 1000, "wall_time_s": 10.0,
                          "heldout_history": [[s, 0.1] for s in steps]},
                  "band_init": {"steps": 300, "wall_time_s": 5.0},
                  "band_fit": {"kept": True, "steps": 1000, "wall_time_s": 10.0,
                               "heldout_history": [[s, w] for s, w in zip(steps, wide)]}}
        folder = tmp_path / "call" / "runs" / scene / "nct"
        folder.mkdir(parents=True)
        band = {"f_max": [0.3, 0.5], "kept_f_max": 0.5 if kept else 0.3}
        (folder / "metrics.json").write_text(json.dumps({"stages": stages, "capacity": {"band": band},
                                                          "wall_time_s": 40.0}))

    run("ahead", [0.2, 0.09, 0.05, 0.05, 0.04, 0.04, 0.04, 0.04, 0.04, 0.04], kept=True)
    run("behind", [0.2, 0.09, 0.08, 0.095, 0.1, 0.1, 0.1, 0.1, 0.1, 0.1], kept=False)
    assert load("diagnostics/band_race").main(["--call", str(tmp_path / "call"), "--at", "0.3", "--gain", "0.9"]) == 0
    # "behind" is ahead at 300 (0.8) and behind at 400 (0.95): stopped there, saving 60 % of its 10 s fit;
    # each run is 40 s, 25 s of it without the band: 1.6x, and 34 / 25 = 1.36x for "behind".
    assert "| 0.3 | 0.9 | 1/2 | 400 | none | 6 of 30 s | 1.60 -> 1.48 |" in capsys.readouterr().out
