"""The scenes an experiment can simulate, as configs, and `build_phantom`, which makes a scene of one
(a composed scene's ellipses and their `Signal`s of time: ``signals.py``).

Scene geometry is given as fractions of the field-of-view side (the image ``extent``) and motion
per gantry rotation; a built `Phantom` (``shapes.py``: images and projections free of inverse
crime) scales by ``grid.extent`` when asked for images or data. Each config dataclass doubles as
the Hydra schema of its ``phantom`` group option.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from nct.acquisition.scanner import ImageGrid
from nct.scenes.letters import LetterPhantom, glyph_polygons, glyph_reach
from nct.scenes.shapes import EllipseParams, EllipsePhantom, Phantom
from nct.scenes.signals import ELLIPSE_KEYS, GRADIENT_KEYS, EllipseConf, Signal, ellipse_phantom, signal_params

FOV_RADIUS = 0.5  # inscribed circle of the unit field of view: objects must stay inside
SIGN_CHECK_SIZE = 48  # a composed scene with negative or graded objects is checked >= 0 on this raster
WAVEFORMS = ("sinusoidal", "physiological")


def _require(ok: bool, key: str, expected: str, got: object) -> None:
    if not ok:
        raise ValueError(f"phantom.{key} must be {expected}, got {got}")


@dataclass
class CircleConf:
    """Paper Fig. 2: a disc on a circular orbit about the FOV centre, travelling
    ``displacement_deg`` of arc (counter-clockwise) per gantry rotation from ``start_deg``."""

    name: str = "circle"
    radius: float = 0.15
    orbit_radius: float = 0.20
    displacement_deg: float = 100.0
    start_deg: float = 0.0
    intensity: float = 1.0

    def __post_init__(self) -> None:
        _require(self.radius > 0, "radius", "> 0", self.radius)
        _require(self.orbit_radius >= 0, "orbit_radius", ">= 0", self.orbit_radius)
        _require(0 <= self.displacement_deg <= 360, "displacement_deg", "in [0, 360]", self.displacement_deg)
        _require(self.intensity > 0, "intensity", "> 0", self.intensity)
        reach = self.radius + self.orbit_radius
        _require(reach <= FOV_RADIUS, "radius + phantom.orbit_radius",
                 f"<= {FOV_RADIUS} (inside the field of view's inscribed circle)", reach)

    def ellipse_objects(self) -> list[EllipseConf]:
        cycles = self.displacement_deg / 360.0
        return [EllipseConf(
            x=Signal(amplitude=self.orbit_radius, cycles_per_rotation=cycles, phase_deg=self.start_deg + 90.0),
            y=Signal(amplitude=self.orbit_radius, cycles_per_rotation=cycles, phase_deg=self.start_deg),
            a=Signal(value=self.radius), b=Signal(value=self.radius),
            intensity=Signal(value=self.intensity))]


@dataclass
class HeartConf:
    """Heart-like ellipse at the centre whose semi-axes scale together by 1 + amplitude·w(phase),
    w in [-1, 1] (see `heart_waveform`), phase = beats_per_rotation·τ + phase_deg/360. One beat
    per rotation is the single-rotation scene; 0.2-0.25 spreads one beat over 4-5 rotations (cine)."""

    name: str = "heart"
    semi_axis_x: float = 0.22
    semi_axis_y: float = 0.16
    amplitude: float = 0.25
    beats_per_rotation: float = 1.0
    waveform: str = "sinusoidal"
    phase_deg: float = 0.0
    intensity: float = 1.0

    def __post_init__(self) -> None:
        _require(self.semi_axis_x > 0, "semi_axis_x", "> 0", self.semi_axis_x)
        _require(self.semi_axis_y > 0, "semi_axis_y", "> 0", self.semi_axis_y)
        _require(0 <= self.amplitude < 1, "amplitude", "in [0, 1)", self.amplitude)
        _require(self.beats_per_rotation >= 0, "beats_per_rotation", ">= 0", self.beats_per_rotation)
        _require(self.waveform in WAVEFORMS, "waveform", f"one of {', '.join(WAVEFORMS)}", repr(self.waveform))
        _require(self.intensity > 0, "intensity", "> 0", self.intensity)
        reach = max(self.semi_axis_x, self.semi_axis_y) * (1 + self.amplitude)
        _require(reach <= FOV_RADIUS, "semi_axis_x/semi_axis_y",
                 f"such that max semi-axis * (1 + amplitude) <= {FOV_RADIUS} (inside the FOV)", reach)


@dataclass
class LettersConf:
    """Paper Fig. 4: glyphs of ``sequence`` (DejaVu Sans Bold, cap height ``glyph_size`` of the FOV)
    morphed one into the next through their signed distance functions over ``rotations`` gantry
    rotations; ``hold_fraction`` of that time is spent stationary, equally at each letter."""

    name: str = "letters"
    sequence: str = "ABCBA"
    glyph_size: float = 0.5
    hold_fraction: float = 0.25
    rotations: float = 1.0
    intensity: float = 1.0

    def __post_init__(self) -> None:
        _require(len(self.sequence) >= 1, "sequence", "a non-empty string", repr(self.sequence))
        _require(self.glyph_size > 0, "glyph_size", "> 0", self.glyph_size)
        _require(0 <= self.hold_fraction < 1, "hold_fraction", "in [0, 1)", self.hold_fraction)
        _require(self.rotations > 0, "rotations", "> 0", self.rotations)
        _require(self.intensity > 0, "intensity", "> 0", self.intensity)
        for char in self.sequence:
            visible = char.isprintable() and not char.isspace() and bool(glyph_polygons(char))
            _require(visible, "sequence", "letters with a visible glyph", repr(self.sequence))
        reach = max(glyph_reach(char, self.glyph_size) for char in self.sequence)
        _require(reach <= FOV_RADIUS, "glyph_size",
                 f"small enough for every glyph to stay within {FOV_RADIUS} of the centre", f"{self.glyph_size} "
                 f"(reach {reach:.3f})")


@dataclass
class StaticConf:
    """A still scene with two intensities: a large rotated ellipse and, apart from it, a small disc."""

    name: str = "static"
    large_intensity: float = 1.0
    small_intensity: float = 0.5

    def __post_init__(self) -> None:
        _require(self.large_intensity > 0, "large_intensity", "> 0", self.large_intensity)
        _require(self.small_intensity > 0, "small_intensity", "> 0", self.small_intensity)

    def ellipse_objects(self) -> list[EllipseConf]:
        return [
            EllipseConf(x=Signal(-0.10), y=Signal(0.05), a=Signal(0.22), b=Signal(0.13), angle_deg=Signal(30.0),
                        intensity=Signal(self.large_intensity)),
            EllipseConf(x=Signal(0.22), y=Signal(-0.17), a=Signal(0.07), b=Signal(0.07),
                        intensity=Signal(self.small_intensity)),
        ]


def _default_composed() -> list[EllipseConf]:
    """An ellipse turning 90 degrees per rotation and, clear of its tip, a fainter disc that bobs
    up and down once and pulses twice per rotation."""
    return [
        EllipseConf(a=Signal(0.25), b=Signal(0.12), angle_deg=Signal(rate=90.0)),
        EllipseConf(x=Signal(0.34), y=Signal(amplitude=0.1, cycles_per_rotation=1.0),
                    a=Signal(0.06, amplitude=0.02, cycles_per_rotation=2.0), b=Signal(0.06, amplitude=0.02,
                    cycles_per_rotation=2.0), intensity=Signal(0.6)),
    ]


@dataclass
class ComposedConf:
    """A scene written in config: ellipses whose every parameter is a `Signal` of time.
    Overlapping objects add their intensities, which must sum to >= 0 everywhere; ``rotations`` is
    the span checked to stay in the FOV (and non-negative)."""

    name: str = "composed"
    objects: list[EllipseConf] = field(default_factory=_default_composed)
    rotations: float = 1.0

    def __post_init__(self) -> None:
        _require(len(self.objects) >= 1, "objects", "a non-empty list", len(self.objects))
        _require(self.rotations > 0, "rotations", "> 0", self.rotations)
        keys = ELLIPSE_KEYS + GRADIENT_KEYS
        max_cycles = max(abs(getattr(o, k).cycles_per_rotation) for o in self.objects for k in keys)
        tau = np.linspace(0.0, self.rotations, int(64 * (1 + max_cycles) * self.rotations) + 2)
        params = signal_params(self.objects)(tau)
        for k, obj in enumerate(params.transpose(1, 0, 2)):
            for col, key in ((2, "a"), (3, "b")):
                low = float(obj[:, col].min())
                _require(low > 0, f"objects[{k}].{key}", "> 0 throughout the scan", f"{low:.4g}")
            low, high = float(obj[:, 5].min()), float(obj[:, 5].max())
            _require(low > 0 or high < 0, f"objects[{k}].intensity", "of one sign and never 0 throughout the scan",
                     f"{low:.4g} to {high:.4g}")
            reach = float((np.hypot(obj[:, 0], obj[:, 1]) + np.maximum(obj[:, 2], obj[:, 3])).max())
            _require(reach <= FOV_RADIUS, f"objects[{k}]",
                     f"inside the FOV's inscribed circle (|centre| + max(a, b) <= {FOV_RADIUS}) throughout the scan",
                     f"{reach:.4g}")
        if (params[..., 5] < 0).any() or any(getattr(o, k) != Signal() for o in self.objects for k in GRADIENT_KEYS):
            coarse = tau[::4]  # 16 times a cycle
            scene = ellipse_phantom(self.objects, 1.0)
            lowest = scene.values(coarse, *ImageGrid(SIGN_CHECK_SIZE).xy()).min(axis=(1, 2))
            low, when = float(lowest.min()), float(coarse[np.argmin(lowest)])
            _require(low >= 0, "objects", "intensities that sum to >= 0 everywhere throughout the scan (a "
                     "negative object inside brighter ones)", f"{low:.4g} at {when:.3g} rotations")

    def ellipse_objects(self) -> list[EllipseConf]:
        return list(self.objects)


PhantomConf = CircleConf | HeartConf | LettersConf | StaticConf | ComposedConf


# ----------------------------------------------------------------------------- from config to phantom


def heart_waveform(phase: np.ndarray, waveform: str) -> np.ndarray:
    """Relative size w in [-1, 1] at cycle ``phase`` (cycles, any real): [T] -> [T].

    Both start at end-diastole (w = 1) and reach end-systole (w = -1) at phase 0.5. "sinusoidal":
    cos(2π·phase). "physiological": rest at w = 1 for phase 0-0.2, fast contraction to -1 by 0.5,
    slow filling back to 1 by 1.0; each piece a half-cosine easing, so w is C¹ and periodic.
    """
    frac = np.mod(np.asarray(phase, dtype=np.float64), 1.0)
    if waveform == "sinusoidal":
        return np.cos(2 * math.pi * frac)
    if waveform != "physiological":
        raise ValueError(f"waveform must be one of {', '.join(WAVEFORMS)}, got {waveform!r}")
    knots, levels = np.array([0.0, 0.2, 0.5, 1.0]), np.array([1.0, 1.0, -1.0, 1.0])
    piece = np.clip(np.searchsorted(knots, frac, side="right") - 1, 0, len(knots) - 2)
    u = (frac - knots[piece]) / (knots[piece + 1] - knots[piece])
    ease = (1 - np.cos(math.pi * u)) / 2
    return levels[piece] + (levels[piece + 1] - levels[piece]) * ease


def _heart_params(conf: HeartConf) -> EllipseParams:
    def params(tau: np.ndarray) -> np.ndarray:
        tau = np.atleast_1d(np.asarray(tau, dtype=np.float64))
        scale = 1 + conf.amplitude * heart_waveform(conf.beats_per_rotation * tau + conf.phase_deg / 360, conf.waveform)
        zero = np.zeros_like(tau)
        cols = [zero, zero, conf.semi_axis_x * scale, conf.semi_axis_y * scale, zero, zero + conf.intensity]
        return np.stack(cols, axis=-1)[:, None, :]

    return params


def build_phantom(conf: PhantomConf, rotation_time: float) -> Phantom:
    """The scene of ``conf`` with motion timed by the gantry's ``rotation_time`` (s per rotation)."""
    if not rotation_time > 0:
        raise ValueError(f"rotation_time must be > 0, got {rotation_time}")
    if isinstance(conf, LettersConf):
        return LetterPhantom(conf.sequence, conf.glyph_size, conf.hold_fraction, conf.rotations, conf.intensity,
                             rotation_time)
    if isinstance(conf, HeartConf):
        return EllipsePhantom(_heart_params(conf), (float(conf.intensity),), rotation_time)
    if isinstance(conf, (CircleConf, StaticConf, ComposedConf)):
        return ellipse_phantom(conf.ellipse_objects(), rotation_time)
    raise ValueError(f"phantom must be one of circle, heart, letters, static, composed, got {type(conf).__name__}")
