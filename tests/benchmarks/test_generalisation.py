"""The generalisation benchmark's own simulator (benchmarks/scenes.py and scene_files.py, independent of nct): a
deterministic sampler that covers its ranges, exact ellipse projections, Poisson noise, and files
that nct's loader and FBP read right in unit field of view, cm and mm; its acceptance checks count
a failed NeuralCT run as Dice 0.

benchmarks/diagnostics/object_levels.py: the brightest-level ratio, and its report on a call's runs.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from nct.acquisition.io import load_sinogram
from nct.acquisition.scanner import ImageGrid
from nct.analysis.benchmarking import Job, Record
from nct.init.segmentation import segmentations
from nct.physics.fbp import fbp_frames
from nct.run.metrics import dice
from tests.conftest import load_benchmark as load

S = load("scenes")
F = load("scene_files")
G = load("generalisation")


def test_sampler_is_deterministic_per_seed_and_scene_index():
    assert S.draw_scenes(3, 6) == S.draw_scenes(3, 6)
    assert S.draw_scenes(3, 6)[:4] == S.draw_scenes(3, 4)
    assert S.draw_scenes(3, 6) != S.draw_scenes(4, 6)


def test_sampler_covers_its_ranges_and_keeps_every_layout_valid():
    scenes = S.draw_scenes(0, 60)
    assert {s.units for s in scenes} == {"unit", "cm", "mm"}
    assert {len(s.objects) for s in scenes} == {1, 2, 3}
    assert {s.layout for s in scenes} == {"single", "apart", "nested"}
    assert {o.motion.kind for s in scenes for o in s.objects} == {"static", *S.MOTIONS}
    assert {s.categories()["family"] for s in scenes} == {"static", "mixed", *S.MOTIONS}
    assert {s.acquisition.direction for s in scenes} == {-1, 1}
    assert {s.acquisition.rotations for s in scenes} == {1, 2, 3, 4}
    assert any(s.noise_i0 is None for s in scenes) and any(s.noise_i0 is not None for s in scenes)
    assert any(not s.moving for s in scenes) and any(s.max_deg_per_rotation >= 150 for s in scenes)
    for s in scenes:
        acq = s.acquisition
        assert S.layout_ok(s)
        assert 90 <= acq.views_per_rotation <= 720 and 0.2 <= acq.rotation_time <= 0.5
        assert s.noise_i0 is None or 1e4 <= s.noise_i0 <= 1e6
        assert 4.0 <= s.smallest_radius_pct() <= 30.0
        assert all(0.2 <= o.intensity <= 2.0 for o in s.objects)
        assert all(5 <= o.motion.deg_per_rotation <= 200 for o in s.objects if o.motion.kind != "static")
        low, high = S.UNITS[s.units]
        assert low <= s.extent <= high


def static_scene(objects, direction: int = 1, units: str = "unit", extent: float = 1.0) -> "S.Scene":
    acq = S.Acquisition(views_per_rotation=180, rotations=1, rotation_time=0.3, direction=direction,
                        start_angle=1.0, time_offset=5.0, detector_width=1.1)
    return S.Scene(0, units, extent, tuple(objects), "nested" if len(objects) > 1 else "single", acq, None)


def test_chords_of_a_centred_disc_match_the_closed_form():
    scene = static_scene([S.Ellipse((0.0, 0.0), 0.3, 0.3, 0.4, 1.0)])
    angles = np.linspace(0, np.pi, 7)
    s = np.tile(np.linspace(-0.4, 0.4, 81), (7, 1))
    chords = F.chord_lengths(S.Pose.of(scene, 0, np.full(7, 5.0)), angles, s)
    np.testing.assert_allclose(chords, 2 * np.sqrt(np.clip(0.09 - s**2, 0, None)), atol=1e-12)


def test_projection_of_an_off_centre_ellipse_has_its_area_and_centroid_at_every_angle():
    scene = static_scene([S.Ellipse((0.12, -0.07), 0.2, 0.08, 0.7, 1.5)])
    values = F.line_integrals(scene, 128)
    n_bins, spacing = F.detector(scene, 128)
    s = (np.arange(n_bins) - (n_bins - 1) / 2) * spacing
    angles = scene.acquisition.angles()
    np.testing.assert_allclose(values.sum(axis=1) * spacing, 1.5 * np.pi * 0.2 * 0.08, rtol=1e-3)
    centroid = (values * s).sum(axis=1) / values.sum(axis=1)
    np.testing.assert_allclose(centroid, 0.12 * np.cos(angles) - 0.07 * np.sin(angles), atol=1e-4)


def test_poisson_noise_is_unbiased_with_the_expected_spread():
    p = np.ones(20000)  # unit FOV: k = 5, 1e4 * exp(-5) = 67 photons a ray
    measured = F.add_noise(p, 1e4, 1.0, np.random.default_rng(0))
    assert measured.mean() == pytest.approx(1.0, abs=0.005)
    assert measured.std() == pytest.approx(1 / (5 * math.sqrt(1e4 * math.exp(-5))), rel=0.05)


@pytest.mark.parametrize("units, extent", [("unit", 1.0), ("cm", 30.0), ("mm", 300.0)])
@pytest.mark.parametrize("direction", [1, -1])
def test_nct_fbp_reads_a_written_static_scene_right_in_every_unit(tmp_path, units, extent, direction):
    objects = [S.Ellipse((0.1, -0.15), 0.2, 0.1, 0.5, 1.5), S.Ellipse((0.12, -0.12), 0.06, 0.05, 0.0, 0.5, parent=0)]
    scene = static_scene(objects, direction, units, extent)
    sino = load_sinogram(F.write_scene(scene, tmp_path / "scene.npz", 48, 2, 0))
    truth = sino.truth
    assert truth.extent == extent and sino.geometry.bin_spacing == pytest.approx(extent / 48)
    assert truth.level == pytest.approx(0.25)
    assert sino.values.max() == pytest.approx(extent * F.line_integrals(scene, 48).max(), rel=1e-6)
    frames = fbp_frames(sino, ImageGrid(48, truth.extent), truth.times)
    assert dice(frames >= truth.level, truth.frames >= truth.level).min() > 0.95
    assert np.abs(frames - truth.frames).mean() < 0.02


def record(method: str, status: str, dice_value: float) -> Record:
    job = Job({"scene": "scene000"}, method, 0, (), Path("/nonexistent"))
    return Record(job=job, status=status, dice=dice_value, mse=0.01)


def test_acceptance_counts_a_failed_nct_run_as_dice_zero_and_a_crash():
    moving = next(s for s in S.draw_scenes(0, 12) if s.moving)
    ok = G.Outcome(moving, record("nct", "ok", 0.95), record("fbp", "ok", 0.90))
    trailing = G.Outcome(moving, record("nct", "ok", 0.885), record("fbp", "ok", 0.90))
    crashed = G.Outcome(moving, record("nct", "failed", math.nan), record("fbp", "ok", 0.90))
    checks = G.acceptance([ok, trailing, crashed])
    assert checks.crashes == [crashed] and checks.below_fbp == [trailing, crashed]
    assert (checks.target_good, checks.target_scenes) == (1, 3)
    assert [line.split(":")[1].split(",")[0].strip() for line in checks.lines()] == ["FAIL", "FAIL", "FAIL"]
    rows = {(r["category"], r["value"]): r for r in G.category_rows([ok, trailing, crashed])}
    assert rows["all", "all"]["nct_dice"] == pytest.approx(0.885) and rows["all", "all"]["nct_failed"] == 1


def test_each_scene_and_family_reports_the_candidate_its_tournament_chose(tmp_path):
    """The winner and its scene model come from the run's table; a model of the scene's own objects on no
    background is right; its moving objects over an image (which holds the still ones) draw the same objects; any
    other K or a background is reported as chosen wrong."""
    by_name = {s.name: s for s in S.draw_scenes(0, 12)}
    # one rotating ellipse; a beating one and a still one; two moving and a still one
    scenes = [by_name["scene002"], by_name["scene008"], by_name["scene004"]]
    runs = []
    for i, (winner, k, background) in enumerate((("free_start1", 1, "none"), ("k1_image_free", 1, "image"),
                                                 ("k1_image_free", 1, "image"))):
        (tmp_path / str(i)).mkdir()
        row = {"candidate": winner, "n_objects": k, "background": background}
        (tmp_path / str(i) / "metrics.json").write_text(json.dumps({"selection": {"winner": winner, "table": [row]}}))
        runs.append(Record(job=Job({"scene": "s"}, "nct", 0, (), tmp_path / str(i)), status="ok", dice=0.9, mse=0.01))
    failed = G.Outcome(scenes[0], record("nct", "failed", math.nan), record("fbp", "ok", 0.9))
    results = [G.Outcome(s, r, record("fbp", "ok", 0.9)) for s, r in zip(scenes, runs)] + [failed]
    assert [o.row()["winner"] for o in results] == ["free_start1", "k1_image_free", "k1_image_free", ""]
    assert [o.row()["model_right"] for o in results] == [True, False, False, None]
    assert [o.row()["model_equivalent"] for o in results] == [True, True, False, None]
    rows = {(r["category"], r["value"]): r for r in G.category_rows(results)}
    assert rows["all", "all"]["winners"] == "k1_image_free:2 free_start1:1 none:1"
    note = G.report(results, G.category_rows(results), G.acceptance(results), "cmd", 1.0)
    assert "own model (one object per ellipse, no background) on 1 of 3 finished runs" in note
    assert "over an image holding the still ones on 1 more" in note


def test_a_told_run_passes_the_scenes_model_and_a_users_run_nothing(tmp_path):
    scene = S.draw_scenes(0, 1)[0]
    told = G.scene_overrides(scene, tmp_path / "f.npz", [])
    assert f"data.n_objects={len(scene.objects)}" in told and "background=none" in told
    assert "background=none" not in G.scene_overrides(scene, tmp_path / "f.npz", ["background=image"], 1)
    assert not any(o.startswith(("data.n_objects", "background")) for o in
                   G.scene_overrides(scene, tmp_path / "f.npz", [], told=False))


def test_acceptance_without_target_scenes_says_so_rather_than_fail():
    """A run of static scenes alone (e.g. --only scene006) has no scene for check (c)."""
    static = next(s for s in S.draw_scenes(0, 12) if not s.moving)
    checks = G.acceptance([G.Outcome(static, record("nct", "ok", 0.99), record("fbp", "ok", 0.99))])
    assert checks.target_scenes == 0
    assert checks.lines()[2].endswith("no such scene") and "PASS" in checks.lines()[1]


def test_own_level_of_a_nested_object_adds_its_containers():
    """Issue 9 item 5's threshold: a vessel (1.0) in a body (0.5) in a shell (0.2) is scored at 0.2 + 0.5 + 0.5."""
    scene = next(s for s in S.draw_scenes(0, 60) if s.layout == "nested")
    body = S.Ellipse((0.0, 0.0), 0.3, 0.3, 0.0, 0.2)
    nested = (body, S.Ellipse((0.0, 0.0), 0.2, 0.2, 0.0, 0.5, parent=0), S.Ellipse((0.0, 0.0), 0.05, 0.05, 0.0, 1.0,
                                                                                   parent=1))
    levels = S.Scene(scene.index, scene.units, scene.extent, nested, "nested", scene.acquisition, None).own_levels()
    assert levels == pytest.approx({1: 0.2 + 0.25, 2: 0.2 + 0.5 + 0.5})
    single = S.Scene(scene.index, scene.units, scene.extent, (body,), "single", scene.acquisition, None)
    assert single.own_levels() == {}


def test_init_candidates_sees_what_the_run_segments(tmp_path):
    """benchmarks/diagnostics/init_candidates.py stops the run where it segments: the judged candidate the run
    kept (metrics.json -> init -> start) has the a(k) it records as its initial levels."""
    from nct.run.job import run_job
    from tests.conftest import compose_config

    objects = [S.Ellipse((0.1, -0.15), 0.2, 0.1, 0.5, 1.5), S.Ellipse((-0.3, 0.2), 0.08, 0.07, 0.0, 0.6)]
    path = F.write_scene(static_scene(objects, 1, "cm", 30.0), tmp_path / "scene.npz", 48, 2, 0)
    overrides = ["image.size=48", "optim.init_steps=2", "optim.fit_steps=2", "logger=none", "export.gif=false",
                 "export.tiff=false", "export.png=false", "background=none"]
    candidates = load("diagnostics/init_candidates")
    frames, k, rng, kappa, share, route, judge, starts = candidates.segmentation_inputs(path, 2, overrides)
    assert frames.ndim == 3 and k == 2 and judge is not None and starts == 2
    ranked = segmentations(frames, k, rng, kappa, share, route, judge)
    run_job(compose_config(["data=file", f"data.path={path}", "data.n_objects=2", *overrides]), tmp_path / "run")
    init = json.loads((tmp_path / "run" / "metrics.json").read_text())["init"]
    assert init["starts_tried"] == 2 and init["start"] in (0, 1)
    kept = ranked[init["start"]]
    np.testing.assert_allclose(np.asarray(kept.intensities) * init["intensity_unit"], init["levels"], rtol=1e-6)
    assert sorted(init["levels"]) == pytest.approx([0.6, 1.5], rel=0.1)


def test_moving_region_sees_the_frames_the_background_starts_from(tmp_path):
    """benchmarks/diagnostics/moving_region.py stops a background=image run where the background starts
    and returns its FBP frames and moving_share; a run without a background, or a bad override, is named,
    not run."""
    from nct.errors import InputError

    objects = [S.Ellipse((0.1, -0.15), 0.2, 0.1, 0.5, 1.5)]
    path = F.write_scene(static_scene(objects, 1, "cm", 30.0), tmp_path / "scene.npz", 48, 2, 0)
    overrides = ["image.size=48", "optim.init_steps=2", "optim.fit_steps=2", "logger=none"]
    region = load("diagnostics/moving_region")
    frames, share = region.region_inputs(path, 1, [*overrides, "background=image", "background.moving_share=0.2"])
    assert frames.ndim == 3 and frames.shape[1:] == (48, 48) and share == 0.2
    with pytest.raises(InputError, match="background=image"):
        region.region_inputs(path, 1, overrides)
    with pytest.raises(InputError, match="image.sizee"):  # a misspelt key: named, no traceback
        region.region_inputs(path, 1, ["image.sizee=48"])


def test_level_choices_compares_the_starts_with_and_without_claimed_levels(tmp_path):
    """benchmarks/diagnostics/level_choices.py counts the judged choices both ways; two still discs apart
    give every class its own mean, so both ways offer the same choices and keep the same starts."""
    objects = [S.Ellipse((0.1, -0.15), 0.2, 0.1, 0.5, 1.5), S.Ellipse((-0.3, 0.2), 0.08, 0.07, 0.0, 0.6)]
    path = F.write_scene(static_scene(objects, 1, "cm", 30.0), tmp_path / "scene.npz", 48, 2, 0)
    choices = load("diagnostics/level_choices").compare(path, 2, ["image.size=48", "logger=none"])
    assert choices.with_claimed >= choices.means_only >= 1 and choices.same_starts


def _disc(radius: float, level: float, size: int = 32) -> np.ndarray:
    y, x = np.mgrid[:size, :size] - (size - 1) / 2
    return np.where(np.hypot(x, y) <= radius, level, 0.0)[None].astype(np.float32)


def test_brightest_ratio_sees_a_disc_drawn_wider_and_fainter():
    levels = load("diagnostics/object_levels")
    truth = _disc(3, 2.0)
    assert levels.brightest_ratio(truth, truth) == pytest.approx(1.0)
    # Twice as wide at half the level: about the same mass, but the true disc's pixels read 1.0.
    assert levels.brightest_ratio(truth, _disc(6, 1.0)) == pytest.approx(0.5)
    assert levels.brightest_ratio(truth, 0.9 * truth) == pytest.approx(0.9)
    with pytest.raises(ValueError, match="differ in shape"):
        levels.brightest_ratio(truth, truth[:, :-1])


def _run(call, scene: str, truth: np.ndarray, nct: np.ndarray, fbp: np.ndarray) -> None:
    folder = call / "runs" / scene / "nct"
    folder.mkdir(parents=True)
    np.savez(folder / "reconstruction.npz", nct=nct, fbp=fbp)
    np.savez(folder / "sinogram.npz", truth=truth)


def test_levels_report_lists_the_scenes_where_nct_is_fainter_than_fbp(tmp_path, capsys):
    levels = load("diagnostics/object_levels")
    call = tmp_path / "call"
    truth = _disc(3, 2.0)
    _run(call, "scene000", truth, _disc(6, 1.0), 0.95 * truth)   # NCT 0.5, FBP 0.95: listed
    _run(call, "scene001", truth, truth, 0.8 * truth)            # NCT 1.0, FBP 0.8: not listed
    (call / "scenes.csv").write_text("scene,layout,radii_pct,nct_status\nscene000,nested,30x20 5x5,ok\n"
                                     "scene001,apart,10x10 4x4,ok\nscene002,single,5x5,failed\n")
    assert levels.main(["--call", str(call), "--out", str(tmp_path / "levels.md")]) == 0
    out = capsys.readouterr().out
    assert "2 scenes" in out and "median NCT 0.750, FBP 0.875" in out and "below 0.9: NCT 1, FBP 1" in out
    assert "| scene000 | nested | 30x20 5x5 | 0.500 | 0.950 |" in out and "| scene001 |" not in out
    assert (tmp_path / "levels.md").read_text() == out.rstrip("\n") + "\n"


def test_levels_report_says_when_there_is_nothing_to_read(tmp_path, capsys):
    levels = load("diagnostics/object_levels")
    assert levels.main(["--call", str(tmp_path)]) == 1
    assert "object_levels: error: no scenes.csv" in capsys.readouterr().err


def test_milestones_replays_a_near_tie_that_the_margin_keeps(tmp_path):
    """benchmarks/diagnostics/milestones.py: a second start 3 % behind at step 300 that ends ahead is stopped
    without a margin (the first start wins instead, in 1300 steps) and races on with 5 %."""
    milestones = load("diagnostics/milestones")
    ahead = [[100 * (i + 1), 1.0] for i in range(10)]
    late = [[100 * (i + 1), 1.03 if i < 5 else 0.9] for i in range(10)]
    model = {"n_objects": 2, "background": "none", "rung": "free", "f_max": None, "turning": None, "restart": False}
    metrics = {"selection": {"table": [{"candidate": "free", **model, "start": 0, "steps": 1000, "heldout_misfit": 1.0},
                                       {"candidate": "free_start1", **model, "start": 1, "steps": 1000,
                                        "heldout_misfit": 0.9}]},
               "stages": {"free_fit": {"planned_steps": 1000, "heldout_history": ahead},
                          "free_start1_fit": {"planned_steps": 1000, "heldout_history": late}}}
    metrics["selection"]["table"].append({"candidate": "rigid", **model, "rung": "rigid", "start": 0, "steps": 0,
                                          "heldout_misfit": float("nan"), "verdict": "not fitted: ..."})
    (tmp_path / "metrics.json").write_text(json.dumps(metrics))
    steps, every, ran = milestones.fits(tmp_path)
    assert (steps, every, len(ran)) == (1000, 100, 2)  # the rung a still scan left out (select/stillness.py) is no fit
    assert milestones.replay(steps, 0, ran, 0.0, 0.5)[0].name == "free_start1"
    winner, used, lines = milestones.replay(steps, every, ran, 0.0, 0.5)
    assert (winner.name, used) == ("free", 1300) and "free_start1 stopped at step 300, +3.0% behind" in lines[0]
    winner, used, lines = milestones.replay(steps, every, ran, 0.05, 0.5)
    assert (winner.name, used, lines) == ("free_start1", 2000, [])


def test_milestones_replays_the_first_milestone_where_first_budget_puts_it(tmp_path):
    """A start far behind stops at the first milestone: step 300 at today's first budget (0.25 of 1000 steps, on the
    checks every 100), step 100 at 0.1; without milestones both fits run to the end."""
    milestones = load("diagnostics/milestones")
    steps = list(range(100, 1001, 100))
    ahead = [0.01 * 1000 / s for s in steps]
    model = {"n_objects": 1, "background": "none", "rung": "free", "f_max": None, "turning": None, "restart": False}
    table, stages = [], {}
    for name, start, history in [("free", 0, ahead), ("free_start1", 1, [2 * x for x in ahead])]:
        table.append({"candidate": name, **model, "start": start, "steps": 1000, "heldout_misfit": history[-1]})
        stages[f"{name}_fit"] = {"planned_steps": 1000, "heldout_history": [list(p) for p in zip(steps, history)]}
    (tmp_path / "metrics.json").write_text(json.dumps({"selection": {"table": table}, "stages": stages}))
    n_steps, every, ran = milestones.fits(tmp_path)
    assert milestones.replay(n_steps, 0, ran, 0.05, 0.5, 1.0)[1] == 2000
    for first, stop in [(0.25, 300), (0.1, 100)]:
        winner, used, lines = milestones.replay(n_steps, every, ran, 0.05, 0.5, first)
        assert winner.name == "free" and used == 1000 + stop and f"stopped at step {stop}" in lines[0]


def test_milestones_replays_the_scene_budget_against_the_truth(tmp_path, capsys, monkeypatch):
    """Three objects 50 % behind two at step 300 that end 30 % ahead: stopped where scene models are compared
    from the first milestone (K = 2 wins, not the truth's), racing on from half the steps (K = 3, the truth's)."""
    milestones = load("diagnostics/milestones")
    two = [[100 * (i + 1), 1.0] for i in range(10)]
    three = [[100 * (i + 1), 1.5 if i < 3 else 0.7] for i in range(10)]
    model = {"background": "none", "rung": "free", "f_max": None, "turning": None, "restart": False, "start": 0}
    metrics = {"selection": {"table": [{"candidate": "k2_none_free", "n_objects": 2, **model, "steps": 1000,
                                        "heldout_misfit": 1.0},
                                       {"candidate": "k3_none_free", "n_objects": 3, **model, "steps": 1000,
                                        "heldout_misfit": 0.7}]},
               "stages": {"k2_none_free_fit": {"planned_steps": 1000, "heldout_history": two},
                          "k3_none_free_fit": {"planned_steps": 1000, "heldout_history": three}}}
    run = tmp_path / "runs" / "scene007" / "nct"
    run.mkdir(parents=True)
    (run / "metrics.json").write_text(json.dumps(metrics))
    (tmp_path / "scenes.csv").write_text("scene,n_objects\nscene007,3\n")
    monkeypatch.setattr("sys.argv", ["milestones", str(tmp_path), "--margin", "0.05", "--scene-budget", "0.25", "0.5"])
    milestones.main()
    out = capsys.readouterr().out
    assert "all finished: k3_none_free (2000 steps); the truth's model k3_none" in out
    assert "scene budget 0.25, first budget 0.25: k2_none_free wins instead, 1300 steps" in out
    assert "scene budget 0.5, first budget 0.25: the same winner, 2000 steps" in out
    assert ("margin 0.05, scene budget 0.25, first budget 0.25: 1300 steps, the winner of no milestones on 0, the "
            "truth's model on 0") in out
    assert ("margin 0.05, scene budget 0.5, first budget 0.25: 2000 steps, the winner of no milestones on 1, the "
            "truth's model on 1") in out


def test_milestones_refuses_a_table_without_the_candidates_models(tmp_path, capsys, monkeypatch):
    """A run written before the candidates were typed records no model per row: one line, exit code 2."""
    milestones = load("diagnostics/milestones")
    metrics = {"selection": {"table": [{"candidate": "free", "rung": "free", "steps": 1000, "heldout_misfit": 1.0}]},
               "stages": {"free_fit": {"planned_steps": 1000, "heldout_history": [[100, 1.0]]}}}
    (tmp_path / "metrics.json").write_text(json.dumps(metrics))
    monkeypatch.setattr("sys.argv", ["milestones", str(tmp_path)])
    with pytest.raises(SystemExit) as exit_:
        milestones.main()
    assert exit_.value.code == 2 and "written by an older nct" in capsys.readouterr().err
