"""benchmarks/diagnostics/scene_model.py (the scene model's truth-free signals) and scene_model_rule.py (the
product's choice of scene model, select/scene.py, scored on them)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from nct.errors import NoObjectError
from nct.run.pipeline import acquire
from nct.select.candidates import BACKGROUND_ORDER, SceneModel
from nct.select.scene import Preparation, offered, price, raced, set_up, up_to_dearer
from tests.conftest import load_benchmark as load

S = load("scenes")
F = load("scene_files")
M = load("diagnostics/scene_model")
R = load("diagnostics/scene_model_rule")
C = load("diagnostics/init_candidates")


def two_levels(path):
    """Two still discs apart, levels 1.5 and 0.6, noiseless, one rotation of 180 views, 48 px."""
    acq = S.Acquisition(views_per_rotation=180, rotations=1, rotation_time=0.3, direction=1, start_angle=1.0,
                        time_offset=0.0, detector_width=1.1)
    objects = (S.Ellipse((0.15, -0.1), 0.2, 0.15, 0.5, 1.5), S.Ellipse((-0.25, 0.2), 0.1, 0.09, 0.0, 0.6))
    return F.write_scene(S.Scene(0, "unit", 1.0, objects, "apart", acq, None), path, 48, 2, 0)


def run_setups(path, models) -> dict:
    """Those of ``models`` a run on the file at ``path`` sets up (select/scene.set_up; none where no object stands
    out), by model."""
    conf = C.run_config(path, None, list(M.RUN))
    scan = acquire(conf, np.random.default_rng(conf.seed))
    prepared = Preparation(scan.sinogram, scan.grid, conf.loss, conf.init, conf.heldout, conf.background,
                           (conf.fbp.filter, conf.fbp.window_deg))
    setups = {}
    for model in models:
        try:
            setups[model] = set_up(prepared, model, conf.seed)
        except NoObjectError:
            continue
    return setups


def test_the_table_holds_what_a_run_prices(tmp_path):
    """Two still levels: the signals tell two objects from one; every model's residual read off the row is the
    one a run computes for the models it offers, and the rule races what the run races (K = 1..2, for time)."""
    path = two_levels(tmp_path / "two.npz")
    row = M.signals(M.SceneFile("two", "generalisation", path, "none", 2, "apart, static static, clean"), k_max=2)
    M.write_csv_rows([row], tmp_path / "signals.csv")
    assert {"r_none1", "r_none2", "r_lone2", "r_image0", "r_image2", "inside_none2"} <= set(row)
    assert {"t_prepare", "t_none1", "t_lone2", "t_static", "t_bic", "noise_floor", "r_fbp", "texture"} <= set(row)
    assert row["moving_share"] == 0 and math.isnan(row["r_image1"])  # nothing moves: no object over a background
    assert row["r_none2"] < 0.3 * row["r_none1"]  # the second level explains what one cannot
    (scene,) = R.read_scenes(tmp_path / "signals.csv")
    assert scene.truth == SceneModel(2, "none")
    models = [m for m in R.MODELS if m.n_objects <= 2]
    setups = {m: s for m, s in run_setups(path, models).items() if offered(s.found.ranked[0], chosen=True)}
    assert SceneModel(1, "image") not in setups  # nothing moves: objects over an image start empty, not offered
    for model in models:
        run = setups[model].judged if model in setups else math.nan
        assert R.judged(scene, model) == pytest.approx(run, rel=1e-9, nan_ok=True), model
    prices = {m: p for b in BACKGROUND_ORDER for m, p in up_to_dearer(
        [m for m in models if m.background == b], lambda m: price(setups[m]) if m in setups else None).items()}
    assert set(raced(prices, scene.value("r_image0"))) == set(R.race(scene))
    assert R.race(scene)[0] == SceneModel(2, "none")


def scene_of(none: list[float], image: list[float], lone: float | None = None, image0: float = 1.0) -> "R.Scene":
    """A row of signals.csv with these judge residuals (K = 1..4; ``lone``: K = 1 on a mover's compensated
    frames), the image's relative to the whole views, whose norm is ``image0`` times that of the views."""
    row = {f"r_{name}{k + 1}": str(r) for name, rs in (("none", none), ("image", image)) for k, r in enumerate(rs)}
    row |= {"r_image0": str(image0), "r_lone1": "" if lone is None else str(lone), "detail": "apart, static, clean"}
    return R.Scene("x", "generalisation", SceneModel(1), row)


def test_an_object_must_pay_for_itself_over_each_background():
    """With the product's price (gain 0.8) and margin (1.25): an added object must cut the residual to 0.8 of it;
    over each background the cheapest is raced, the runner-up too within 1.25 of it, none first (an image whose
    start alone leaves 0.3 of the views earns its place)."""
    assert R.race(scene_of([0.1, 0.11, 0.11, 0.11], [0.5, 0.7, 0.7, 0.7], image0=0.3)) == [SceneModel(1),
                                                                                          SceneModel(1, "image")]
    assert R.race(scene_of([0.1, 0.09, 0.09, 0.09], [math.nan] * 4)) == [SceneModel(1), SceneModel(2)]
    two = [0.1, 0.04, 0.045, 0.045]  # K = 2 priced 0.0625 (0.04 / 0.8**2), K = 3 0.088, K = 1 0.125
    assert R.race(scene_of(two, [math.nan] * 4)) == [SceneModel(2)]
    assert R.race(scene_of(two, [0.02, 0.03, 0.03, 0.03])) == [SceneModel(2), SceneModel(1, "image")]
    assert R.race(scene_of(two, [0.04, 0.04, 0.1, 0.1], image0=0.3), R.Rule(margin=1.0)) == [
        SceneModel(2), SceneModel(1, "image")]
    assert R.race(scene_of(two, [0.04, 0.04, 0.1, 0.1], image0=0.3)) == [
        SceneModel(2), SceneModel(1, "image"), SceneModel(2, "image")]  # 0.05, 0.0625: within 1.25
    assert R.k_right(R.Scene("x", "generalisation", SceneModel(2), scene_of(two, [0.5] * 4).row), R.Rule())


def test_the_residuals_a_run_prices():
    """K = 1 without a background reads the compensated frames where the views hold a path; over an image, the
    residual relative to the whole views, as every model's; a rim among several objects, objects the judge gives
    no intensity, or objects over an image where nothing moves, are not offered."""
    scene = scene_of([0.3, 0.2, 0.19, 0.19], [0.02] * 4, lone=0.1, image0=0.25)
    assert R.judged(scene, SceneModel(1)) == 0.1 and R.judged(scene, SceneModel(2)) == 0.2
    assert R.judged(scene, SceneModel(3, "image")) == 0.02
    assert R.judged(scene_of([0.3] * 4, [0.02] * 4), SceneModel(1)) == 0.3
    scene.row["inside_none2"] = "0.05"  # a rim: under MIN_INTERIOR of its pixels inside
    assert math.isnan(R.judged(scene, SceneModel(2))) and R.judged(scene, SceneModel(3)) == 0.19
    scene.row["a_image1"] = "5e-14"  # the judge's floor: the object explains none of the views
    assert math.isnan(R.judged(scene, SceneModel(1, "image"))) and R.judged(scene, SceneModel(2, "image")) == 0.02
    scene.row["moving_share"] = "0"  # nothing moves: a run's objects over the image start empty
    assert math.isnan(R.judged(scene, SceneModel(2, "image")))


def test_rule_note_names_a_missing_table(tmp_path, capsys):
    with pytest.raises(SystemExit) as stop:
        R.main([str(tmp_path / "none.csv")])
    assert stop.value.code == 2 and "none.csv" in capsys.readouterr().err


def test_rule_note_scores_a_table(tmp_path, capsys):
    """The note's accuracy counts the truth proposed and raced per category."""
    scenes = [scene_of(none, [0.5] * 4, image0=0.3) for none in ([0.1, 0.04, 0.045, 0.045], [0.1, 0.11, 0.11, 0.11])]
    note = R.report([R.Scene(f"s{i}", "generalisation", SceneModel(2), s.row) for i, s in enumerate(scenes)],
                    R.Rule(), "cmd")
    assert "| generalisation | 2 | 1 (50%) | 1 (50%) | 3.00 |" in note and "**1 / 1**" in note
