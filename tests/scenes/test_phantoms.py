"""Scenes from their configs: motion as configured, Hydra schemas, validation naming the key; the
thorax and nodule experiments (a moving part inside static, textured anatomy)."""

import math
from dataclasses import replace
from functools import cache
from pathlib import Path

import numpy as np
import pytest
from omegaconf import OmegaConf

import nct.conf
from nct.acquisition.scanner import ImageGrid, Scanner
from nct.scenes.phantoms import (
    CircleConf,
    ComposedConf,
    HeartConf,
    LettersConf,
    StaticConf,
    build_phantom,
    heart_waveform,
)
from nct.scenes.signals import EllipseConf, Signal

T_ROT = 0.25


def centroid(img: np.ndarray, grid: ImageGrid) -> np.ndarray:
    x, y = grid.xy()
    return np.array([(img * x).sum(), (img * y).sum()]) / img.sum()


def dice(a: np.ndarray, b: np.ndarray, level: float) -> float:
    a, b = a > level, b > level
    return 2 * (a & b).sum() / (a.sum() + b.sum())


# ------------------------------------------------------------------ motion


def test_circle_travels_displacement_per_rotation():
    grid = ImageGrid(128)
    phantom = build_phantom(CircleConf(displacement_deg=100.0, start_deg=10.0), T_ROT)
    c0, c1 = (centroid(phantom.image(t, grid), grid) for t in (0.0, T_ROT))
    assert np.hypot(*c0) == pytest.approx(0.2, abs=1e-3)
    assert math.degrees(math.atan2(*c0[::-1])) == pytest.approx(10.0, abs=0.3)
    assert math.degrees(math.atan2(*c1[::-1])) == pytest.approx(110.0, abs=0.3)


def test_circle_without_displacement_is_static():
    grid = ImageGrid(32)
    phantom = build_phantom(CircleConf(displacement_deg=0.0), T_ROT)
    frames = phantom.frames(np.linspace(0, T_ROT, 5), grid)
    assert np.array_equal(frames, np.broadcast_to(frames[0], frames.shape))
    moving = build_phantom(CircleConf(displacement_deg=5.0), T_ROT).frames(np.array([0.0, T_ROT]), grid)
    assert not np.array_equal(moving[0], moving[1])


def test_moving_circle_projection_follows_each_view_time():
    phantom = build_phantom(CircleConf(displacement_deg=150.0), T_ROT)
    grid = ImageGrid(32)
    scanner = Scanner(views_per_rotation=36, rotations=1.0, rotation_time=T_ROT, n_bins=64, bin_spacing=1 / 48)
    sino = phantom.project(scanner, grid).astype(np.float64)
    centre = (sino * scanner.bin_positions).sum(axis=1) / sino.sum(axis=1)
    x, y = phantom.ellipses(scanner.times)[:, 0, :2].T
    # a one-view timing slip would move the centre by ~3e-3
    assert np.allclose(centre, x * np.cos(scanner.angles) + y * np.sin(scanner.angles), atol=2e-4)


@pytest.mark.parametrize("waveform", ["sinusoidal", "physiological"])
def test_heart_axes_follow_waveform(waveform):
    conf = HeartConf(semi_axis_x=0.2, semi_axis_y=0.15, amplitude=0.2, beats_per_rotation=0.25, waveform=waveform)
    phantom = build_phantom(conf, T_ROT)
    beat = T_ROT / 0.25
    t = np.linspace(0, 2 * beat, 801)
    a, b = phantom.ellipses(t)[:, 0, 2:4].T
    assert a.max() == pytest.approx(0.24) and a.min() == pytest.approx(0.16)
    assert np.allclose(b / a, 0.75)
    assert t[np.argmin(a[:400])] == pytest.approx(beat / 2)  # end-systole mid-beat
    assert np.allclose(a[:400], a[400:800])  # period: one beat
    grid = ImageGrid(64)
    areas = [phantom.image(s, grid).sum() / 64**2 for s in (0.0, beat / 2)]
    assert areas == pytest.approx([math.pi * 0.24 * 0.18, math.pi * 0.16 * 0.12], rel=0.02)


def test_physiological_waveform_rests_then_contracts_fast_and_fills_slowly():
    phase = np.linspace(0, 1, 1001)
    w = heart_waveform(phase, "physiological")
    assert np.allclose(w[phase <= 0.2], 1.0)
    assert w.min() == pytest.approx(-1.0) and phase[np.argmin(w)] == pytest.approx(0.5)
    slope = np.diff(w) / np.diff(phase)
    assert -slope.min() > 1.5 * slope.max()  # contraction faster than filling
    assert np.abs(np.diff(slope)).max() < 0.5  # C1: no kinks between pieces
    assert heart_waveform(np.array([0.3, 1.3, -0.7]), "physiological") == pytest.approx([w[300]] * 3)


def test_letters_holds_are_distinct_glyphs_and_morph_smoothly():
    phantom = build_phantom(LettersConf(sequence="ABCBA", hold_fraction=0.25), T_ROT)
    grid = ImageGrid(64)
    holds = phantom.hold_times()
    assert holds.shape == (5,)
    frames = phantom.frames(holds, grid)
    level = 0.5
    assert dice(frames[0], frames[2], level) < 0.7  # A vs C
    assert dice(frames[0], frames[1], level) < 0.9  # A vs B
    assert dice(frames[0], frames[4], level) > 0.98  # the two A holds
    assert dice(frames[1], frames[3], level) > 0.98
    hold = 0.25 * T_ROT / 5
    still = phantom.frames(holds[2] + np.array([-0.45, 0.45]) * hold, grid)
    assert np.array_equal(still[0], still[1])
    morph = phantom.frames(np.linspace(holds[0], holds[1], 40), grid)
    step = np.abs(np.diff(morph, axis=0)).sum(axis=(1, 2))
    assert step.max() < 0.15 * np.abs(frames[1] - frames[0]).sum()


# ------------------------------------------------------------------ config


def test_composed_scene_from_yaml_moves_as_specified():
    yaml = """
    name: composed
    rotations: 2.0
    objects:
      - x: {value: -0.1, rate: 0.05}
        y: {amplitude: 0.1, cycles_per_rotation: 1.0, phase_deg: 90}
        a: {value: 0.1}
        b: {value: 0.05}
        angle_deg: {rate: 45}
      - x: {value: 0.25}
        a: {value: 0.06}
        b: {value: 0.06}
        intensity: {value: 0.5}
    """
    merged = OmegaConf.merge(OmegaConf.structured(ComposedConf), OmegaConf.create(yaml))
    conf = OmegaConf.to_object(merged)
    assert isinstance(conf, ComposedConf) and isinstance(conf.objects[0].x, Signal)
    phantom = build_phantom(conf, T_ROT)
    assert phantom.intensities == (1.0, 0.5)
    p = phantom.ellipses(np.array([0.0, T_ROT / 4, T_ROT]))
    assert p[:, 0, 0] == pytest.approx([-0.1, -0.0875, -0.05])
    assert p[:, 0, 1] == pytest.approx([0.1, 0.0, 0.1], abs=1e-12)
    assert p[:, 0, 4] == pytest.approx(np.deg2rad([0.0, 11.25, 45.0]))
    grid = ImageGrid(64)
    img = phantom.image(0.0, grid)
    assert img.max() == pytest.approx(1.0) and img[grid.size // 2, int(0.75 * grid.size)] == pytest.approx(0.5)


@pytest.mark.parametrize("schema", [CircleConf, HeartConf, LettersConf, StaticConf, ComposedConf])
def test_confs_work_as_structured_configs(schema):
    conf = OmegaConf.to_object(OmegaConf.structured(schema))
    assert conf == schema()
    phantom = build_phantom(conf, T_ROT)
    assert len(phantom.intensities) >= 1 and min(phantom.intensities) > 0


def test_static_scene_has_two_intensities():
    phantom = build_phantom(StaticConf(), T_ROT)
    assert phantom.intensities == (1.0, 0.5)
    img = phantom.image(0.3, ImageGrid(64))
    assert set(np.unique(img).round(6)) >= {0.0, 0.5, 1.0} and img.max() == 1.0  # apart: never 1.5


@pytest.mark.parametrize("make, key", [
    (lambda: CircleConf(displacement_deg=400.0), r"phantom\.displacement_deg"),
    (lambda: CircleConf(radius=0.35), r"phantom\.radius"),
    (lambda: CircleConf(intensity=0.0), r"phantom\.intensity"),
    (lambda: HeartConf(waveform="square"), r"phantom\.waveform"),
    (lambda: HeartConf(semi_axis_x=0.45), r"phantom\.semi_axis_x"),
    (lambda: LettersConf(glyph_size=1.2), r"phantom\.glyph_size"),
    (lambda: LettersConf(sequence=" "), r"phantom\.sequence"),
    (lambda: LettersConf(hold_fraction=1.0), r"phantom\.hold_fraction"),
    (lambda: StaticConf(small_intensity=-1.0), r"phantom\.small_intensity"),
    (lambda: ComposedConf(objects=[EllipseConf(x=Signal(0.1, rate=0.5))]), r"phantom\.objects\[0\] must"),
    (lambda: ComposedConf(objects=[EllipseConf(), EllipseConf(a=Signal(0.05, amplitude=0.1,
                                                                       cycles_per_rotation=1.0))]),
     r"phantom\.objects\[1\]\.a"),
    (lambda: ComposedConf(objects=[EllipseConf(intensity=Signal(0.2, amplitude=0.3, cycles_per_rotation=1.0))]),
     r"phantom\.objects\[0\]\.intensity must be of one sign"),
    (lambda: ComposedConf(objects=[EllipseConf(a=Signal(0.3)), EllipseConf(x=Signal(0.25), intensity=Signal(-0.5))]),
     r"phantom\.objects must be intensities that sum to >= 0"),  # a lung poking out of its body
    (lambda: ComposedConf(objects=[EllipseConf(a=Signal(0.3), gradient_x=Signal(5.0))]), r"phantom\.objects must"),
])
def test_bad_values_raise_naming_the_key(make, key):
    with pytest.raises(ValueError, match=key):
        make()


def test_bad_value_fails_when_config_is_built():
    bad = OmegaConf.merge(OmegaConf.structured(CircleConf), {"displacement_deg": 400})
    with pytest.raises(ValueError, match=r"phantom\.displacement_deg must be in \[0, 360\], got 400"):
        OmegaConf.to_object(bad)


# ------------------------------------------------------------------ moving parts inside static anatomy

ANATOMY = {  # experiment: its moving objects' indices, K
    "thorax": ((7, 8), 2),
    "nodule": ((1, 2, 3), 3),
}


@cache
def experiment_scene(name: str) -> tuple[ComposedConf, int, float]:
    """The phantom, K and rotations an experiment sets (its YAML read directly: Hydra's composition of
    it is tests/run/test_config.py's)."""
    exp = OmegaConf.load(Path(nct.conf.__file__).parent / "experiment" / f"{name}.yaml")
    rotations = float(exp.scanner.rotations)
    conf = OmegaConf.to_object(OmegaConf.merge(OmegaConf.structured(ComposedConf), exp.phantom,
                                               {"rotations": rotations}))
    return conf, int(exp.data.n_objects), rotations


@pytest.mark.parametrize("experiment", ANATOMY)
def test_anatomy_experiments_build_with_a_still_surround(experiment):
    conf, n_objects, rotations = experiment_scene(experiment)
    moving, k = ANATOMY[experiment]
    assert n_objects == k
    still = [i for i in range(len(conf.objects)) if i not in moving]
    for i, obj in enumerate(conf.objects):
        signals = [getattr(obj, key) for key in ("x", "y", "a", "b", "angle_deg", "intensity")]
        assert any(s.amplitude or s.rate for s in signals) == (i in moving), i
    phantom = build_phantom(conf, T_ROT)
    grid = ImageGrid(48)
    times = np.linspace(0.0, rotations * T_ROT, 7)
    frames = phantom.frames(times, grid, supersample=2)
    assert np.isfinite(frames).all() and frames.min() >= 0
    # The still part does not move: only pixels the moving objects reach change.
    params = phantom.ellipses(times)[:, list(moving)]
    x, y = grid.xy()
    reach = np.zeros(x.shape, bool)
    for cx, cy, a, b, *_ in params.reshape(-1, 6):
        reach |= np.hypot(x - cx, y - cy) <= max(a, b) + grid.pixel_size
    changed = np.ptp(frames, axis=0) > 0
    assert changed.any() and not changed[~reach].any()
    # The moving parts' own levels lie above every still part's intensity outside them, so that
    # each is scored alone (the thorax's myocardium: the whole heart).
    levels = phantom.levels(times)
    brightest_still = frames[:, ~reach].max()
    assert min(levels[i] for i in moving if conf.objects[i].intensity.value > 0) > brightest_still
    assert len(levels) == len(conf.objects) and len(still) >= 1


def test_thorax_surround_is_textured():
    """Not piecewise constant: inside the body, hardly any two vertical neighbours are equal (a
    piecewise-constant chest: most of them)."""
    conf = experiment_scene("thorax")[0]
    frame = build_phantom(conf, T_ROT).image(0.0, ImageGrid(64), supersample=2)
    pairs = (frame[1:] > 0.1) & (frame[:-1] > 0.1)
    equal = np.isclose(frame[1:], frame[:-1], rtol=0, atol=1e-6)[pairs]
    assert equal.mean() < 0.1
    flat = [replace(o, gradient_x=Signal(), gradient_y=Signal()) for o in conf.objects]
    frame = build_phantom(ComposedConf(objects=flat), T_ROT).image(0.0, ImageGrid(64), 2)
    assert np.isclose(frame[1:], frame[:-1], rtol=0, atol=1e-6)[pairs].mean() > 0.5
