"""Textured static surroundings (issue 29, item 4; benchmarks/scenes.py `draw_textured_scene`,
benchmarks/textured.py): the families' draws are reproducible and hold what they promise, moving
objects stay inside the body and clear of its inclusions, a graded body's exact projections agree
with a fine rasterisation, the generalisation benchmark's scenes are unchanged, and one tiny call of
the script writes its tables."""

from __future__ import annotations

import csv
import math

import numpy as np
import pytest

from tests.conftest import load_benchmark as load
from tests.conftest import ray_end_points, rel_l2, siddon

S = load("scenes")
F = load("scene_files")
T = load("textured")
E = load("diagnostics/edge_errors")


def test_textured_draws_are_reproducible_per_seed_family_and_index():
    scenes = S.draw_textured_scenes(0, 3)
    assert scenes == S.draw_textured_scenes(0, 3)
    assert [s.layout for s in scenes] == [f for f in S.FAMILIES for _ in range(3)]
    assert S.draw_textured_scene(0, "holes", 2) == scenes[8]
    assert scenes != S.draw_textured_scenes(1, 3)
    with pytest.raises(ValueError, match="family"):
        S.draw_textured_scene(0, "marble", 0)


def test_the_generalisation_scenes_are_unchanged():
    """Seed 0's scenes 2 and 79 as drawn and simulated before the textured families (main 619c18e)."""
    single, nested = S.draw_scene(0, 2), S.draw_scene(0, 79)
    assert (single.units, single.extent, single.layout, single.noise_i0) == ("mm", 280.48755839871745, "single",
                                                                             33324.1616059163)
    assert single.acquisition == S.Acquisition(314, 1, 0.24353007056464326, -1, 2.054216441677446,
                                               1.183416852627438, 1.0565235535713946)
    assert single.objects == (S.Ellipse((0.025622091068744617, -0.0697868527869586), 0.3, 0.22499999999999998,
                                        1.7684518832662024, 0.6566312009160717,
                                        S.Motion("rotation", 175.48789580890562, 0.0, 0.23038515161096604,
                                                 2.3909204957490338)),)
    assert (nested.units, nested.extent, nested.layout, nested.noise_i0) == ("mm", 378.47842711225076, "nested", None)
    assert nested.objects[1] == S.Ellipse((0.0, 0.0), 0.17725977858567446, 0.17725977858567446, 1.2686779743545884,
                                          1.8567958807967433, S.Motion("beat", 158.2030566781169, 0.12318876312407508,
                                                                       1.727751246498563, 2.003673575154999), 0)
    assert nested.objects[0].motion == S.Motion("translation", 155.32149013902364, 0.17701526212102964,
                                                1.3337982057025908, 1.9217169615241239)
    for scene, sums in ((single, (1399.1134859601589, 285.10104797035456)),
                        (nested, (4326.337469006044, 857.4781320095062))):
        values = F.line_integrals(scene, 32)
        truth = F.rasterise(scene, F.truth_times(scene, 2), 32)
        assert (values.sum(), truth.astype(float).sum()) == pytest.approx(sums, rel=1e-12)


def _moving_clear(scene) -> None:
    """Every moving object inside the body (object 0) and clear of every other object at every checked time."""
    times = S._check_times(scene)
    poses = [S.Pose.of(scene, i, times) for i in range(len(scene.objects))]
    body = scene.objects[0]
    for i, obj in enumerate(scene.objects):
        if obj.motion.kind == "static":
            continue
        p = poses[i]
        assert np.all(np.hypot(p.cx - poses[0].cx, p.cy - poses[0].cy) + p.a <= body.b), (scene.layout, scene.index)
        for j in range(1, len(scene.objects)):
            if j != i:
                q = poses[j]
                assert np.all(np.hypot(p.cx - q.cx, p.cy - q.cy) >= p.a + q.a), (scene.layout, scene.index, i, j)


def test_each_family_holds_what_it_promises():
    for scene in S.draw_textured_scenes(0, 8):
        body, rest = scene.objects[0], scene.objects[1:]
        moving = [o for o in rest if o.motion.kind != "static"]
        static = [o for o in rest if o.motion.kind == "static"]
        assert body.motion.kind == "static" and body.parent is None and all(o.parent == 0 for o in rest)
        assert 1 <= len(moving) <= 2 and {o.motion.kind for o in moving} <= set(S.TEXTURED_MOTIONS)
        assert S.layout_ok(scene, S.TEXTURED_RADIUS_RANGE)
        _moving_clear(scene)
        rise = math.hypot(*body.gradient) * body.a + max([0.0, *(o.intensity for o in static)])
        levels = T.moving_levels(scene)
        assert all(levels[i] >= body.intensity + rise + S.LEVEL_MARGIN - 1e-12 for i in levels)
        if scene.layout == "gradient":
            assert not static
            assert 0.25 <= math.hypot(*body.gradient) * body.a / body.intensity <= 0.45
        elif scene.layout == "structures":
            assert 3 <= len(static) <= 4
            assert any(o.intensity > 0 for o in static) and any(o.intensity < 0 for o in static)
            assert all(0.02 <= o.b <= o.a <= 0.06 for o in static)
            assert body.gradient == (0.0, 0.0)
        else:
            assert 1 <= len(static) <= 2
            assert all(-0.95 * body.intensity <= o.intensity <= -0.7 * body.intensity for o in static)
            assert body.gradient == (0.0, 0.0)


def test_inclusions_show_in_the_truth():
    """Rasterised: the gradient family's body spans its rise, the holes family's lungs sit far below it."""
    for family in ("gradient", "holes"):
        scene = S.draw_textured_scene(0, family, 0)
        frame = F.rasterise(scene, F.truth_times(scene, 1)[:1], 64)[0]
        body = scene.objects[0]
        inside = frame[frame > 0]
        if family == "gradient":
            rise = math.hypot(*body.gradient) * body.a
            assert inside.min() < body.intensity - 0.7 * rise and np.percentile(inside, 90) > body.intensity + 0.4 * rise
        else:
            assert inside.min() < 0.35 * body.intensity


def _graded_scene(views: int):
    body = S.Ellipse((0.03, -0.02), 0.4, 0.32, 0.6, 0.6, gradient=(0.5, -0.35))
    vessel = S.Ellipse((0.1, 0.05), 0.07, 0.05, 0.3, 1.2, S.Motion("orbit", 100.0, 0.08, 1.0, 0.4), parent=0)
    lung = S.Ellipse((-0.15, -0.05), 0.14, 0.08, 1.2, -0.5, parent=0)
    acq = S.Acquisition(views_per_rotation=views, rotations=1, rotation_time=0.3, direction=1, start_angle=0.4,
                        time_offset=2.0, detector_width=1.05)
    return S.Scene(0, "unit", 1.0, (body, vessel, lung), "gradient", acq, None)


def test_a_graded_body_projects_to_its_area_times_its_centre_value():
    """The linear part integrates to zero over an ellipse about its centre: every view's total is intensity × area."""
    scene = _graded_scene(12)
    scene = S.Scene(0, "unit", 1.0, scene.objects[:1], "single", scene.acquisition, None)
    values = F.line_integrals(scene, 96)
    np.testing.assert_allclose(values.sum(axis=1) / 96, 0.6 * np.pi * 0.4 * 0.32, rtol=2e-3)


def test_textured_projections_match_a_fine_rasterisation():
    """Exact line integrals (graded chords, a moving vessel, a lung) against Siddon's lengths through the
    truth rasterised at 256 px, view by view at the view's time, the same sub-rays a bin."""
    scene = _graded_scene(6)
    size, fine = 48, 256
    values = F.line_integrals(scene, size)
    n_bins, spacing = F.detector(scene, size)
    u = ((np.arange(n_bins) - (n_bins - 1) / 2)[:, None] * spacing
         + ((np.arange(F.SUB_RAYS) + 0.5) / F.SUB_RAYS - 0.5)[None, :] * spacing).ravel()
    angles, times = scene.acquisition.angles(), scene.acquisition.times()
    reference = np.empty_like(values)
    for v in range(angles.size):
        image = F.rasterise(scene, times[v : v + 1], fine)[0].astype(np.float64)
        start, end = ray_end_points(angles[v : v + 1], u, reach=1.0)
        reference[v] = siddon(image, 1.0, start, end).reshape(n_bins, F.SUB_RAYS).mean(axis=1)
    assert rel_l2(values, reference) < 0.005  # measured 0.0022; without the chord's shift along the ray 0.020
    assert np.abs(values - reference).max() < 0.01 * values.max()


def test_plan_takes_the_moving_objects_over_a_background_and_every_object_without(tmp_path):
    scene = S.draw_textured_scene(0, "structures", 0)
    jobs = T.plan(tmp_path, [scene], [tmp_path / "s.npz"], ["image", "none"], ["optim.fit_steps=5"])
    n_moving = sum(o.motion.kind != "static" for o in scene.objects)
    assert [j.labels["background"] for j in jobs] == ["image", "none"]
    assert [j.run_dir for j in jobs] == [tmp_path / "runs" / "structures000" / b for b in ("image", "none")]
    assert "background=image" in jobs[0].overrides and f"data.n_objects={n_moving}" in jobs[0].overrides
    assert "background=none" in jobs[1].overrides and f"data.n_objects={len(scene.objects)}" in jobs[1].overrides
    assert jobs[0].overrides[-1] == "optim.fit_steps=5"
    [auto] = T.plan(tmp_path, [scene], [tmp_path / "s.npz"], ["auto"], [])
    assert not any(o.startswith(("background=", "data.n_objects=")) for o in auto.overrides)  # nothing passed


def test_a_tiny_call_writes_its_tables(tmp_path, capsys):
    """One scene (the fewest views of the first two gradient scenes), 32 px, 5-step fits, background=image."""
    scene = min((S.draw_textured_scene(0, "gradient", i) for i in range(2)), key=lambda s: s.acquisition.n_views)
    name, k = T.scene_name(scene), str(len(T.moving_levels(scene)))
    out = tmp_path / "call"
    assert T.main(["--out", str(out), "--scenes", "2", "--families", "gradient", "--only", name, "--size", "32",
                   "--frames", "4", "--backgrounds", "image", "--override", "optim.init_steps=5",
                   "--override", "optim.fit_steps=5", "--override", "threads=1"]) == 0
    with open(out / "textured.csv") as fh:
        rows = list(csv.DictReader(fh))
    assert [(r["scene"], r["background"], r["K"], r["nct_status"]) for r in rows] == [(name, "image", k, "ok")]
    assert float(rows[0]["fbp_mse"]) > 0 and 0 <= float(rows[0]["fbp_own_dice"]) <= 1
    text = (out / "textured.md").read_text()
    assert "## Per family" in text and f"| {name} | image |" in text
    assert (out / "families.csv").is_file() and (out / "scenes" / f"{name}.npz").is_file()
    assert "NCT/FBP MSE" in capsys.readouterr().out
    assert E.main([str(out), name]) == 0  # benchmarks/diagnostics/edge_errors.py reads what the call wrote
    report = capsys.readouterr().out
    assert f"{name}, background=image: a(k)" in report and report.count("  level ") == int(k)
    with pytest.raises(SystemExit, match="not a textured scene"):
        E.main([str(out), "marble000"])


def test_edge_errors_counts_a_disc_drawn_a_pixel_too_large_at_its_edge_alone():
    yy, xx = np.mgrid[:32, :32]
    radius = np.hypot(yy - 15.5, xx - 15.5)
    truth, larger = (radius < 8)[None] * 1.0, (radius < 9)[None] * 1.0
    fp, fn = E.edge_errors(larger, truth, 0.5)
    ring = int(((radius < 9) & (radius >= 8)).sum())
    assert dict(fp) == {1: ring} and not fn
    far = larger.copy()
    far[0, 0, 0] = 1.0  # a stray pixel far from the disc
    fp, _ = E.edge_errors(far, truth, 0.5)
    assert fp[E.FAR_PX] == 1 and fp[1] == ring
    fp, fn = E.edge_errors(truth, larger, 0.5)
    assert not fp and dict(fn) == {1: ring}


def test_plateaus_measure_the_background_under_where_a_mover_always_lies_against_its_surroundings():
    truth = np.zeros((2, 24, 24))
    truth[0, 8:14, 6:14], truth[1, 8:14, 8:16] = 1.0, 1.0  # a block moving right: its middle columns always covered
    background = np.full((24, 24), 0.5)
    background[8:14, 8:14] += 0.2
    assert E.plateaus(background, truth, 0.5) == [(36, pytest.approx(0.2))]
    assert E.plateaus(np.full((24, 24), 0.5), truth, 0.5) == [(36, pytest.approx(0.0))]
