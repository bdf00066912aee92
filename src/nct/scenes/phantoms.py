"""Time-varying scenes with ground truth at any time and projections free of inverse crime.

Scene geometry is given as fractions of the field-of-view side (the image ``extent``) and motion
per gantry rotation; a built `Phantom` scales by ``grid.extent`` when asked for images or data.
Each config dataclass doubles as the Hydra schema of its ``phantom`` group option.

Detector model (all scenes): a bin's value is the mean line integral over the bin's width (box
aperture), every view at its own instant, along the scanner geometry's rays (parallel or fan
beam). Ellipses use the exact integral of their closed-form chord length (in fan beam over the
strip of lines at the bin's centre-ray angle between the ray offsets of its edges: within 1e-3 of
the mean over the bin's fan of rays); other scenes are rasterised 4x finer than the grid and
projected pixel-driven.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from collections.abc import Callable
from dataclasses import dataclass, field
from functools import lru_cache

import numpy as np
from matplotlib.font_manager import FontProperties
from matplotlib.path import Path
from matplotlib.textpath import TextPath
from scipy.ndimage import distance_transform_edt

from nct.acquisition.scanner import ImageGrid, Scanner

FOV_RADIUS = 0.5  # inscribed circle of the unit field of view: objects must stay inside
PROJECT_REFINE = 4  # rasterised scenes are projected from a grid this many times finer
WAVEFORMS = ("sinusoidal", "physiological")
_GLYPH_FONT = FontProperties(family="DejaVu Sans", weight="bold")


def _require(ok: bool, key: str, expected: str, got: object) -> None:
    if not ok:
        raise ValueError(f"phantom.{key} must be {expected}, got {got}")


# ----------------------------------------------------------------------------- configs


@dataclass
class Signal:
    """A scalar over time τ = t / rotation_time (rotations):
    value + rate·τ + amplitude·sin(2π(cycles_per_rotation·τ + phase_deg/360))."""

    value: float = 0.0
    rate: float = 0.0
    amplitude: float = 0.0
    cycles_per_rotation: float = 0.0
    phase_deg: float = 0.0

    def at(self, tau: np.ndarray) -> np.ndarray:
        """The signal at times ``tau`` in rotations: [T] -> [T] float64."""
        tau = np.asarray(tau, dtype=np.float64)
        wave = np.sin(2 * math.pi * (self.cycles_per_rotation * tau + self.phase_deg / 360.0))
        return self.value + self.rate * tau + self.amplitude * wave


@dataclass
class EllipseConf:
    """One ellipse of a composed scene: centre (x, y) and semi-axes a (along the ellipse's own x
    axis) and b as fractions of the FOV side, rotation ``angle_deg`` counter-clockwise, intensity."""

    x: Signal = field(default_factory=Signal)
    y: Signal = field(default_factory=Signal)
    a: Signal = field(default_factory=lambda: Signal(value=0.1))
    b: Signal = field(default_factory=lambda: Signal(value=0.1))
    angle_deg: Signal = field(default_factory=Signal)
    intensity: Signal = field(default_factory=lambda: Signal(value=1.0))


EllipseParams = Callable[[np.ndarray], np.ndarray]
_KEYS = ("x", "y", "a", "b", "angle_deg", "intensity")


def _signal_params(objects: list[EllipseConf]) -> EllipseParams:
    """Ellipse parameters from Signals: τ [T] -> [T, K, 6] (x, y, a, b, angle rad, intensity)."""

    def params(tau: np.ndarray) -> np.ndarray:
        tau = np.atleast_1d(np.asarray(tau, dtype=np.float64))
        out = np.stack([np.stack([getattr(o, k).at(tau) for k in _KEYS], axis=-1) for o in objects], axis=1)
        out[..., 4] = np.deg2rad(out[..., 4])
        return out

    return params


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
            visible = char.isprintable() and not char.isspace() and bool(_glyph_polygons(char))
            _require(visible, "sequence", "letters with a visible glyph", repr(self.sequence))
        reach = max(_glyph_reach(char, self.glyph_size) for char in self.sequence)
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
    Overlapping objects add their intensities; ``rotations`` is the span checked to stay in the FOV."""

    name: str = "composed"
    objects: list[EllipseConf] = field(default_factory=_default_composed)
    rotations: float = 1.0

    def __post_init__(self) -> None:
        _require(len(self.objects) >= 1, "objects", "a non-empty list", len(self.objects))
        _require(self.rotations > 0, "rotations", "> 0", self.rotations)
        max_cycles = max(abs(getattr(o, k).cycles_per_rotation) for o in self.objects for k in _KEYS)
        tau = np.linspace(0.0, self.rotations, int(64 * (1 + max_cycles) * self.rotations) + 2)
        params = _signal_params(self.objects)(tau)
        for k, obj in enumerate(params.transpose(1, 0, 2)):
            for col, key in ((2, "a"), (3, "b"), (5, "intensity")):
                low = float(obj[:, col].min())
                _require(low > 0, f"objects[{k}].{key}", "> 0 throughout the scan", f"{low:.4g}")
            reach = float((np.hypot(obj[:, 0], obj[:, 1]) + np.maximum(obj[:, 2], obj[:, 3])).max())
            _require(reach <= FOV_RADIUS, f"objects[{k}]",
                     f"inside the FOV's inscribed circle (|centre| + max(a, b) <= {FOV_RADIUS}) throughout the scan",
                     f"{reach:.4g}")

    def ellipse_objects(self) -> list[EllipseConf]:
        return list(self.objects)


PhantomConf = CircleConf | HeartConf | LettersConf | StaticConf | ComposedConf

# ----------------------------------------------------------------------------- phantoms


class Phantom(ABC):
    """A time-varying scene. ``intensities``: one per object (K = len); times in seconds."""

    intensities: tuple[float, ...]
    rotation_time: float

    @abstractmethod
    def image(self, t: float, grid: ImageGrid, supersample: int = 4) -> np.ndarray:
        """Intensity at time ``t``, area-averaged over supersample² sub-pixels: [H, W] float32."""

    def frames(self, times: np.ndarray, grid: ImageGrid, supersample: int = 4) -> np.ndarray:
        """`image` at each of ``times`` [F]: [F, H, W] float32."""
        return np.stack([self.image(float(t), grid, supersample) for t in np.asarray(times)])

    @abstractmethod
    def project(self, scanner: Scanner, grid: ImageGrid) -> np.ndarray:
        """Line integrals of every view at its own time: [n_views, n_bins] float32."""


def _block_mean(fine: np.ndarray, factor: int) -> np.ndarray:
    """Average ``factor`` x ``factor`` blocks: [H*f, W*f] -> [H, W] float32."""
    h, w = fine.shape[0] // factor, fine.shape[1] // factor
    return fine.reshape(h, factor, w, factor).mean(axis=(1, 3)).astype(np.float32)


def _check_supersample(supersample: int) -> None:
    if int(supersample) != supersample or supersample < 1:
        raise ValueError(f"supersample must be an integer >= 1, got {supersample}")


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


class EllipsePhantom(Phantom):
    """A sum of moving ellipses with exact (closed-form) projections.

    ``params``: τ (rotations) [T] -> [T, K, 6] columns x, y, a, b (FOV fractions), angle (rad,
    counter-clockwise), intensity.
    """

    def __init__(self, params: EllipseParams, intensities: tuple[float, ...], rotation_time: float) -> None:
        self._params = params
        self.intensities = intensities
        self.rotation_time = rotation_time

    def ellipses(self, times: np.ndarray, extent: float = 1.0) -> np.ndarray:
        """Ellipse parameters at ``times`` (s) [T] with lengths scaled by ``extent``: [T, K, 6]."""
        p = self._params(np.asarray(times, dtype=np.float64) / self.rotation_time)
        p[..., :4] *= extent
        return p

    def image(self, t: float, grid: ImageGrid, supersample: int = 4) -> np.ndarray:
        _check_supersample(supersample)
        x, y = grid.refined(supersample).xy()
        fine = np.zeros_like(x)
        for cx, cy, a, b, angle, intensity in self.ellipses(np.array([t]), grid.extent)[0]:
            dx, dy = x - cx, y - cy
            u = (dx * math.cos(angle) + dy * math.sin(angle)) / a
            v = (-dx * math.sin(angle) + dy * math.cos(angle)) / b
            fine += intensity * (u * u + v * v <= 1.0)
        return _block_mean(fine, supersample)

    def project(self, scanner: Scanner, grid: ImageGrid) -> np.ndarray:
        """Exact mean over each bin of the chord length 2ab·sqrt(h² − σ'²)/h² along the scanner's rays,
        with h² = a²cos²φ' + b²sin²φ', φ' = φ − angle, σ' = σ − (x cos φ + y sin φ), (φ, σ) a ray's
        normal form (``geometry.py``). A bin is the strip of lines at its centre ray's φ between the σ
        of its edges: in parallel beam exactly the bin; in fan beam it neglects the bin's angular width."""
        geometry = scanner.geometry
        phi, _ = geometry.lines(scanner.angles, geometry.bin_positions)
        _, edges = geometry.lines(scanner.angles, geometry.bin_edges)
        phi = np.broadcast_to(phi, (scanner.n_views, scanner.n_bins))
        edges = np.broadcast_to(edges, (scanner.n_views, scanner.n_bins + 1))
        sino = np.zeros((scanner.n_views, scanner.n_bins))
        for obj in self.ellipses(scanner.times, grid.extent).transpose(1, 2, 0):
            cx, cy, a, b, angle, intensity = obj[:, :, None]
            h = np.sqrt((a * np.cos(phi - angle)) ** 2 + (b * np.sin(phi - angle)) ** 2)
            centre = cx * np.cos(phi) + cy * np.sin(phi)
            lo, hi = (np.clip(side - centre, -h, h) for side in (edges[:, :-1], edges[:, 1:]))
            area = (_chord_antiderivative(hi, h) - _chord_antiderivative(lo, h)) * a * b / (h * h)
            sino += intensity * area / np.diff(edges, axis=1)
        return sino.astype(np.float32)


def _chord_antiderivative(s: np.ndarray, h: np.ndarray) -> np.ndarray:
    """∫ 2·sqrt(h² − s²) ds (up to a constant), for |s| <= h: the area under a unit disc's chords."""
    return s * np.sqrt(np.maximum(h * h - s * s, 0.0)) + h * h * np.arcsin(s / h)


# ----------------------------------------------------------------------------- letters


@lru_cache(maxsize=64)
def _glyph_polygons(char: str) -> tuple[np.ndarray, ...]:
    """Outline polygons of ``char`` at font size 1 (cap height ~0.73), each [P, 2]."""
    return tuple(np.asarray(p) for p in TextPath((0, 0), char, size=1, prop=_GLYPH_FONT).to_polygons())


def _glyph_layout(char: str, glyph_size: float) -> tuple[float, np.ndarray]:
    """Scale and offset placing ``char`` with cap height ``glyph_size``, bounding box centred."""
    scale = glyph_size / _glyph_polygons("H")[0][:, 1].max()
    pts = np.concatenate(_glyph_polygons(char))
    return scale, -(pts.min(axis=0) + pts.max(axis=0)) / 2


def _glyph_reach(char: str, glyph_size: float) -> float:
    """Largest distance from the FOV centre of the placed glyph's outline (FOV fractions)."""
    scale, offset = _glyph_layout(char, glyph_size)
    return float(max(np.hypot(*((p + offset) * scale).T).max() for p in _glyph_polygons(char)))


@lru_cache(maxsize=4)
def _glyph_sdfs(chars: str, glyph_size: float, size: int) -> np.ndarray:
    """Signed distance (fine pixels, positive inside) of each glyph on a size² grid of unit
    extent, rows y-down: [len(chars), size, size] float32. Holes by the even-odd rule."""
    x, y = ImageGrid(size, 1.0).xy()
    pts = np.column_stack([x.ravel(), y.ravel()])
    out = np.empty((len(chars), size, size), dtype=np.float32)
    for i, char in enumerate(chars):
        scale, offset = _glyph_layout(char, glyph_size)
        inside = np.zeros(len(pts), dtype=bool)
        for poly in _glyph_polygons(char):
            inside ^= Path((poly + offset) * scale).contains_points(pts)
        inside = inside.reshape(size, size)
        out[i] = distance_transform_edt(inside) - distance_transform_edt(~inside)
    return out


class LetterPhantom(Phantom):
    """Glyphs morphing A→B→C→B→A: at each time the blend (1−w)·sdf_k + w·sdf_{k+1} > 0, with
    w a half-cosine ease across each morph, so shapes change smoothly and topology may change."""

    def __init__(self, conf: LettersConf, rotation_time: float) -> None:
        self.conf = conf
        self.intensities = (float(conf.intensity),)
        self.rotation_time = rotation_time

    def _durations(self) -> tuple[float, float]:
        """Hold and morph durations in rotations."""
        n, span = len(self.conf.sequence), self.conf.rotations
        hold = self.conf.hold_fraction * span / n
        return hold, (span - n * hold) / (n - 1) if n > 1 else 0.0

    def hold_times(self) -> np.ndarray:
        """Middle of each letter's stationary hold, in seconds: [len(sequence)]."""
        hold, morph = self._durations()
        return (np.arange(len(self.conf.sequence)) * (hold + morph) + hold / 2) * self.rotation_time

    def state(self, times: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Letter index k [T] int and eased blend weight w [T] toward letter k+1 at ``times`` (s) [T];
        the first letter holds before 0 and the last after the scene's span."""
        hold, morph = self._durations()
        last = len(self.conf.sequence) - 1
        tau = np.clip(np.asarray(times, dtype=np.float64) / self.rotation_time, 0.0, self.conf.rotations)
        if last == 0:
            return np.zeros(tau.shape, dtype=int), np.zeros(tau.shape)
        k = np.minimum(np.floor(tau / (hold + morph)).astype(int), last)
        w = np.clip((tau - k * (hold + morph) - hold) / morph, 0.0, 1.0)
        return k, (1 - np.cos(math.pi * w)) / 2

    def _sdfs(self, size: int) -> np.ndarray:
        """SDF of each letter of the sequence on a size² grid: [len(sequence), size, size]."""
        chars = "".join(dict.fromkeys(self.conf.sequence))
        sdfs = _glyph_sdfs(chars, float(self.conf.glyph_size), size)
        return sdfs[[chars.index(c) for c in self.conf.sequence]]

    def _fine_mask(self, k: int, w: float, sdfs: np.ndarray) -> np.ndarray:
        """Occupancy of letter k blended toward k+1 by w (w = 0 also serves the last letter)."""
        if w == 0.0:
            return sdfs[k] > 0
        return (1 - w) * sdfs[k] + w * sdfs[k + 1] > 0

    def image(self, t: float, grid: ImageGrid, supersample: int = 4) -> np.ndarray:
        _check_supersample(supersample)
        (k,), (w,) = self.state(np.array([t]))
        fine = self._fine_mask(int(k), float(w), self._sdfs(grid.size * supersample))
        return _block_mean(fine * np.float32(self.conf.intensity), supersample)

    def project(self, scanner: Scanner, grid: ImageGrid) -> np.ndarray:
        """Pixel-driven: each occupied fine pixel's mass goes to sub-bins (``PROJECT_REFINE`` per
        bin) by linear interpolation of the detector coordinate it projects to, over the width of
        detector that sees it (``Geometry.project_points``); sub-bins are averaged per bin."""
        geometry = scanner.geometry
        fine = grid.refined(PROJECT_REFINE)
        sdfs = self._sdfs(fine.size)
        x, y = (c.ravel() for c in fine.xy())
        n_sub = scanner.n_bins * PROJECT_REFINE
        sub_width = scanner.bin_spacing / PROJECT_REFINE
        first_centre = geometry.bin_edges[0] + sub_width / 2
        mass = self.conf.intensity * fine.pixel_size**2 / sub_width
        sino = np.zeros((scanner.n_views, n_sub))
        ks, ws = self.state(scanner.times)
        for view, (theta, k, w) in enumerate(zip(scanner.angles, ks, ws)):
            on = self._fine_mask(int(k), float(w), sdfs).ravel()
            u, scale = (a[0] for a in geometry.project_points(x[on], y[on], np.array([theta])))
            u = (u - first_centre) / sub_width
            lo = np.floor(u).astype(np.int64)
            frac = u - lo
            idx = np.concatenate([lo, lo + 1])
            wts = np.concatenate([1 - frac, frac]) * np.tile(scale, 2)
            keep = (idx >= 0) & (idx < n_sub)
            sino[view] = np.bincount(idx[keep], wts[keep], minlength=n_sub)
        sino *= mass
        return sino.reshape(scanner.n_views, scanner.n_bins, PROJECT_REFINE).mean(axis=2).astype(np.float32)


# ----------------------------------------------------------------------------- factory


def build_phantom(conf: PhantomConf, rotation_time: float) -> Phantom:
    """The scene of ``conf`` with motion timed by the gantry's ``rotation_time`` (s per rotation)."""
    if not rotation_time > 0:
        raise ValueError(f"rotation_time must be > 0, got {rotation_time}")
    if isinstance(conf, LettersConf):
        return LetterPhantom(conf, rotation_time)
    if isinstance(conf, HeartConf):
        return EllipsePhantom(_heart_params(conf), (float(conf.intensity),), rotation_time)
    if isinstance(conf, (CircleConf, StaticConf, ComposedConf)):
        objects = conf.ellipse_objects()
        return EllipsePhantom(_signal_params(objects), tuple(float(o.intensity.value) for o in objects),
                              rotation_time)
    raise ValueError(f"phantom must be one of circle, heart, letters, static, composed, got {type(conf).__name__}")
