"""Random moving-ellipse scenes, drawn by code of their own (not nct's).

The generalisation benchmark (issue 9, item 6) tests ``nct data=file`` on sinogram files written
by independent code, as a user's would be. This module draws scenes from a seed and says where
each object is at any time; ``scene_files.py`` simulates them and writes the files. Neither
imports anything from ``nct``.

Everything is drawn and simulated in a unit field of view (side 1, centred at the origin); a scene
in cm or mm is the same scene scaled: lengths × extent, line integrals (intensity × length) ×
extent, intensities (per unit length) unchanged as numbers.

Motion of an object, with its speed ``deg_per_rotation`` D (a phase that advances D degrees per
gantry rotation):
- static: D = 0;
- orbit: the centre circles an orbit centre at radius ``amplitude``; D is the arc per rotation
  (the paper's measure);
- translation: the centre moves back and forth, ``amplitude`` · sin(phase) along a fixed direction:
  the shadow on a line of an orbit of radius ``amplitude`` at D degrees per rotation;
- rotation: the ellipse turns about its own centre by D degrees per rotation (its axes differ by
  at least 25 %, so the turn is visible);
- beat: both semi-axes scale by 1 + ``amplitude`` · sin(phase); D = 360 is one beat per rotation
  (the paper's heart).
A nested object rides on its container: its centre is the container's centre plus its own offset
and motion.

Textured scenes (issue 29, item 4; `draw_textured_scene`): 1-2 moving objects, brighter than what
surrounds them, inside a static body whose surroundings are not uniform, in three families:
``gradient`` (the body's intensity varies linearly across it), ``structures`` (small static
ellipses brighter and darker than the body) and ``holes`` (static low-intensity inclusions, lungs:
negative intensities added to the body's). Intensities of overlapping objects add, as everywhere.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

UNITS: dict[str, tuple[float, float]] = {"unit": (1.0, 1.0), "cm": (20.0, 40.0), "mm": (200.0, 400.0)}
MOTIONS = ("orbit", "translation", "rotation", "beat")
RADIUS_RANGE = (0.04, 0.30)  # semi-axes, fraction of the field of view's side, at every time
INTENSITY_RANGE = (0.2, 2.0)
MAX_DEG_PER_ROTATION = 200.0
MIN_DEG_PER_ROTATION = 5.0  # a moving object moves visibly
AMPLITUDE_RANGE = {"orbit": (0.05, 0.30), "translation": (0.03, 0.20), "beat": (0.1, 0.3)}
VIEWS_RANGE = (90, 720)
ROTATIONS_RANGE = (1, 4)
ROTATION_TIME_RANGE = (0.2, 0.5)
I0_RANGE = (1e4, 1e6)  # log-uniform, for the noisy scenes
P_STATIC_SCENE, P_NOISELESS, P_NESTED = 0.2, 1 / 3, 0.5
FOV_RADIUS = 0.45  # objects stay inside this circle (unit FOV): the detector sees them at every angle
GAP = 0.02  # clearance between objects apart, and between a nested object and its container's edge
CHECK_SAMPLES = 256  # times at which the layout constraints are checked
MAX_TRIES = 2000
SMALL_PCT = 6.0  # 'small' scenes: some semi-axis below this % of the FOV's side


@dataclass(frozen=True)
class Motion:
    """How an object moves (module docstring): ``kind`` static | orbit | translation | rotation | beat;
    ``deg_per_rotation`` D; ``amplitude``: orbit radius or translation half-range (unit FOV), or the
    beat's relative scale; ``direction``: translation direction (rad) or orbit sense (+1/-1);
    ``phase``: phase at the start of the acquisition (rad)."""

    kind: str = "static"
    deg_per_rotation: float = 0.0
    amplitude: float = 0.0
    direction: float = 1.0
    phase: float = 0.0

    def __post_init__(self) -> None:
        if self.kind not in ("static", *MOTIONS):
            raise ValueError(f"Motion.kind must be static or one of {MOTIONS}, got {self.kind!r}")


@dataclass(frozen=True)
class Ellipse:
    """One object: ``centre`` (unit FOV; an orbit's centre, relative to the container when nested),
    semi-axes ``a`` along ``angle`` (rad) and ``b`` across it, ``intensity`` (attenuation per unit
    length), ``motion``, ``parent``: index of its container (None: not nested); ``gradient`` (gx, gy):
    intensity added per unit length along x and y from the centre (a static object's texture: the
    intensity at (x, y) inside is ``intensity`` + gx (x − cx) + gy (y − cy))."""

    centre: tuple[float, float]
    a: float
    b: float
    angle: float
    intensity: float
    motion: Motion = Motion()
    parent: int | None = None
    gradient: tuple[float, float] = (0.0, 0.0)


@dataclass(frozen=True)
class Acquisition:
    """Parallel-beam scan: views per rotation, whole rotations, seconds per rotation, sense (+1 angles
    increase, -1 decrease), start angle (rad), time of the first view (s), detector width as a
    multiple of the field of view's side (>= 1)."""

    views_per_rotation: int
    rotations: int
    rotation_time: float
    direction: int
    start_angle: float
    time_offset: float
    detector_width: float = 1.0

    @property
    def n_views(self) -> int:
        return self.views_per_rotation * self.rotations

    @property
    def duration(self) -> float:
        return self.rotations * self.rotation_time

    def times(self) -> np.ndarray:
        """Acquisition time of every view, s: [V]."""
        return self.time_offset + np.arange(self.n_views) * self.rotation_time / self.views_per_rotation

    def angles(self) -> np.ndarray:
        """Gantry angle of every view, rad: [V] (not wrapped: rotations accumulate)."""
        return self.start_angle + self.direction * 2 * np.pi * np.arange(self.n_views) / self.views_per_rotation


@dataclass(frozen=True)
class Scene:
    """A drawn scene: ``index`` in its benchmark, ``units`` unit | cm | mm, ``extent`` (the field of
    view's side in those units), ``objects``, ``layout`` single | apart | nested, the scan, and the
    Poisson ``noise_i0`` (None: noiseless)."""

    index: int
    units: str
    extent: float
    objects: tuple[Ellipse, ...]
    layout: str
    acquisition: Acquisition
    noise_i0: float | None

    @property
    def name(self) -> str:
        return f"scene{self.index:03d}"

    @property
    def moving(self) -> bool:
        return any(o.motion.kind != "static" for o in self.objects)

    @property
    def max_deg_per_rotation(self) -> float:
        return max(o.motion.deg_per_rotation for o in self.objects)

    def smallest_radius_pct(self) -> float:
        """The smallest semi-axis of any object at any time, % of the field of view's side."""
        return 100 * min(float(Pose.of(self, i, _check_times(self)).b.min()) for i in range(len(self.objects)))

    def categories(self) -> dict[str, str]:
        """Labels to group results by: motion, family (the moving objects' kind of motion, "mixed" for
        several), size (small: a semi-axis < ``SMALL_PCT`` % of the FOV at some time), noise, layout,
        speed (fast: >= 150 deg/rot), units."""
        kinds = sorted({o.motion.kind for o in self.objects} - {"static"})
        return {"motion": "moving" if self.moving else "static",
                "family": kinds[0] if len(kinds) == 1 else "mixed" if kinds else "static",
                "size": "small" if self.smallest_radius_pct() < SMALL_PCT else "normal",
                "noise": "noisy" if self.noise_i0 is not None else "clean",
                "layout": self.layout,
                "speed": "fast" if self.max_deg_per_rotation >= 150 else "slow" if self.moving else "none",
                "units": self.units}

    def own_levels(self) -> dict[int, float]:
        """Issue 9 item 5's threshold for each nested object: its containers' intensities plus half
        its own (it adds to them), by object index; empty when nothing is nested."""

        def below(i: int) -> float:
            parent = self.objects[i].parent
            return 0.0 if parent is None else self.objects[parent].intensity + below(parent)

        return {i: below(i) + 0.5 * o.intensity for i, o in enumerate(self.objects) if o.parent is not None}

    def parameters(self) -> dict:
        """Every drawn parameter as a flat row (radii as % of the FOV's side)."""
        acq = self.acquisition
        return {"scene": self.name, "units": self.units, "extent": self.extent, "n_objects": len(self.objects),
                "layout": self.layout, "radii_pct": " ".join(f"{100 * o.a:.1f}x{100 * o.b:.1f}" for o in self.objects),
                "smallest_radius_pct": self.smallest_radius_pct(),
                "intensities": " ".join(f"{o.intensity:.2f}" for o in self.objects),
                "motions": " ".join(o.motion.kind for o in self.objects),
                "deg_per_rotation": " ".join(f"{o.motion.deg_per_rotation:.0f}" for o in self.objects),
                "max_deg_per_rotation": self.max_deg_per_rotation, "views_per_rotation": acq.views_per_rotation,
                "rotations": acq.rotations, "rotation_time_s": acq.rotation_time,
                "direction": "ccw" if acq.direction > 0 else "cw", "start_angle_deg": math.degrees(acq.start_angle),
                "time_offset_s": acq.time_offset, "noise_i0": self.noise_i0 if self.noise_i0 is not None else ""}


@dataclass(frozen=True)
class Pose:
    """An object's centre, semi-axes and orientation at a set of times, each [T] (unit FOV)."""

    cx: np.ndarray
    cy: np.ndarray
    a: np.ndarray
    b: np.ndarray
    angle: np.ndarray

    @staticmethod
    def of(scene: Scene, i: int, times: np.ndarray) -> "Pose":
        """Pose of ``scene.objects[i]`` at absolute ``times`` [T] s (a nested object rides on its parent)."""
        obj, acq = scene.objects[i], scene.acquisition
        m = obj.motion
        elapsed = (np.asarray(times, float) - acq.time_offset) / acq.rotation_time  # in rotations
        phase = m.phase + np.radians(m.deg_per_rotation) * elapsed
        ones = np.ones_like(phase)
        cx, cy, scale, angle = obj.centre[0] * ones, obj.centre[1] * ones, ones, obj.angle * ones
        if m.kind == "orbit":
            cx, cy = cx + m.amplitude * np.cos(m.direction * phase), cy + m.amplitude * np.sin(m.direction * phase)
        elif m.kind == "translation":
            shift = m.amplitude * np.sin(phase)
            cx, cy = cx + shift * np.cos(m.direction), cy + shift * np.sin(m.direction)
        elif m.kind == "rotation":
            angle = angle + phase - m.phase
        elif m.kind == "beat":
            scale = 1 + m.amplitude * np.sin(phase)
        if obj.parent is not None:
            host = Pose.of(scene, obj.parent, times)
            cx, cy = cx + host.cx, cy + host.cy
        return Pose(cx, cy, obj.a * scale, obj.b * scale, angle)


def _check_times(scene: Scene) -> np.ndarray:
    acq = scene.acquisition
    return acq.time_offset + np.linspace(0, acq.duration, CHECK_SAMPLES)


def layout_ok(scene: Scene, radius_range: tuple[float, float] = RADIUS_RANGE) -> bool:
    """Whether, at every checked time, every object lies inside the FOV circle, has semi-axes within
    ``radius_range``, nested objects lie inside their container (bounding circles) and all others
    are apart from each other by ``GAP``."""
    times = _check_times(scene)
    poses = [Pose.of(scene, i, times) for i in range(len(scene.objects))]
    for p in poses:
        outside = np.any(np.hypot(p.cx, p.cy) + p.a > FOV_RADIUS)
        if outside or p.b.min() < radius_range[0] or p.a.max() > radius_range[1]:
            return False
    for i, oi in enumerate(scene.objects):
        for j in range(i + 1, len(scene.objects)):
            oj, pi, pj = scene.objects[j], poses[i], poses[j]
            dist = np.hypot(pi.cx - pj.cx, pi.cy - pj.cy)
            if oj.parent == i:
                if np.any(dist + pj.a > pi.b - GAP):
                    return False
            elif np.any(dist < pi.a + pj.a + GAP):
                return False
    return True


def draw_scene(seed: int, index: int) -> Scene:
    """Scene ``index`` of the benchmark seeded ``seed``: its own generator (seed, index), so a scene does
    not depend on how many are drawn. Layouts that break `layout_ok` are drawn again."""
    rng = np.random.default_rng([seed, index])
    units, extent, acquisition, noise_i0 = draw_setting(rng)
    n_objects = int(rng.integers(1, 4))
    layout = "single" if n_objects == 1 else "nested" if rng.random() < P_NESTED else "apart"
    static = rng.random() < P_STATIC_SCENE
    for _ in range(MAX_TRIES):
        objects = draw_objects(rng, n_objects, layout, static)
        scene = Scene(index, units, extent, objects, layout, acquisition, noise_i0)
        if layout_ok(scene):
            return scene
    raise RuntimeError(f"scene {index} (seed {seed}): no valid layout in {MAX_TRIES} tries")


def draw_scenes(seed: int, n: int) -> list[Scene]:
    """The first ``n`` scenes of the benchmark seeded ``seed``."""
    return [draw_scene(seed, i) for i in range(n)]


def draw_setting(rng: np.random.Generator) -> tuple[str, float, Acquisition, float | None]:
    """Units, extent, scanner and noise (I0, None: noiseless) of a scene, in that order from ``rng``."""
    units = str(rng.choice(list(UNITS)))
    low, high = UNITS[units]
    extent = float(rng.uniform(low, high))
    acquisition = draw_acquisition(rng)
    noise_i0 = None if rng.random() < P_NOISELESS else float(np.exp(rng.uniform(*np.log(I0_RANGE))))
    return units, extent, acquisition, noise_i0


def draw_acquisition(rng: np.random.Generator) -> Acquisition:
    """Views per rotation log-uniform in 90-720, 1-4 rotations, 0.2-0.5 s each, either sense, any
    start angle, first view at 0-10 s, detector 1-1.15 times the FOV's side."""
    views = int(round(np.exp(rng.uniform(*np.log(VIEWS_RANGE)))))
    rotations = int(rng.integers(ROTATIONS_RANGE[0], ROTATIONS_RANGE[1] + 1))
    return Acquisition(views_per_rotation=views, rotations=rotations,
                       rotation_time=float(rng.uniform(*ROTATION_TIME_RANGE)), direction=int(rng.choice([-1, 1])),
                       start_angle=float(rng.uniform(0, 2 * np.pi)), time_offset=float(rng.uniform(0, 10)),
                       detector_width=float(rng.uniform(1.0, 1.15)))


def draw_objects(rng: np.random.Generator, n: int, layout: str, static: bool) -> tuple[Ellipse, ...]:
    """``n`` ellipses, largest first, semi-minor axes log-uniform in ``RADIUS_RANGE``; nested: objects
    1.. inside object 0 (their centres and motions relative to it). In a moving scene each object
    moves with probability 0.6, at least one does."""
    sizes = sorted(np.exp(rng.uniform(*np.log(RADIUS_RANGE), size=n)), reverse=True)
    moving = np.zeros(n, bool) if static else rng.random(n) < 0.6
    if not static and not moving.any():
        moving[rng.integers(n)] = True
    objects: list[Ellipse] = []
    for i, b in enumerate(sizes):
        parent = 0 if layout == "nested" and i > 0 else None
        kind = str(rng.choice(MOTIONS)) if moving[i] else "static"
        room = FOV_RADIUS if parent is None else inner_room(objects[0])
        objects.append(draw_ellipse(rng, float(b), room, parent, kind))
    return tuple(objects)


def inner_room(host: Ellipse) -> float:
    """Radius of the circle, about its centre, that stays inside ``host`` at every time, less ``GAP``."""
    shrink = 1 - host.motion.amplitude if host.motion.kind == "beat" else 1.0
    return host.b * shrink - GAP


def draw_ellipse(rng: np.random.Generator, b: float, room: float, parent: int | None, kind: str) -> Ellipse:
    """One ellipse of semi-minor axis about ``b`` (its "radius") moving as ``kind``, built to stay within
    ``room`` of the origin (or its parent's centre): the motion's amplitude is drawn first, the
    semi-major axis from the aspect ratio (0.6-1; 0.5-0.75 for a rotation, so that the turn shows),
    both shrunk to fit if they must, then the centre is drawn in the room left."""
    motion = draw_motion(rng, kind, room - b)
    swing = motion.amplitude if kind in ("orbit", "translation") else 0.0
    grow = 1 + motion.amplitude if kind == "beat" else 1.0
    aspect = rng.uniform(0.5, 0.75) if kind == "rotation" else rng.uniform(0.6, 1.0)
    a = min(b / aspect, RADIUS_RANGE[1], (room - swing) / grow)
    b = min(b, a * (0.75 if kind == "rotation" else 1.0))
    reach = max(room - swing - a * grow, 0.0)
    r, phi = reach * np.sqrt(rng.random()), rng.uniform(0, 2 * np.pi)
    return Ellipse(centre=(float(r * np.cos(phi)), float(r * np.sin(phi))), a=float(a), b=float(b),
                   angle=float(rng.uniform(0, np.pi)), intensity=float(rng.uniform(*INTENSITY_RANGE)),
                   motion=motion, parent=parent)


def draw_motion(rng: np.random.Generator, kind: str, free: float) -> Motion:
    """A motion of ``kind`` at 5-200 deg/rot. Amplitude (``AMPLITUDE_RANGE``): orbit radius 5-30 %,
    translation half-range 3-20 % of the FOV, capped at 80 % of the ``free`` room around the object;
    beat 10-30 % of the axes."""
    if kind == "static":
        return Motion()
    low, high = AMPLITUDE_RANGE.get(kind, (0.0, 0.0))
    if kind in ("orbit", "translation"):
        high = max(low, min(high, 0.8 * free))
    direction = float(rng.choice([-1.0, 1.0])) if kind == "orbit" else float(rng.uniform(0, np.pi))
    return Motion(kind, float(rng.uniform(MIN_DEG_PER_ROTATION, MAX_DEG_PER_ROTATION)), float(rng.uniform(low, high)),
                  direction, float(rng.uniform(0, 2 * np.pi)))


# Textured static surroundings (issue 29, item 4): a static body, its texture, 1-2 moving objects inside.
FAMILIES = ("gradient", "structures", "holes")
TEXTURED_MOTIONS = ("orbit", "translation", "beat")
TEXTURED_RADIUS_RANGE = (0.02, 0.45)  # layout_ok's bounds for textured scenes: small structures, a large body
BODY_A_RANGE, BODY_ASPECT_RANGE, BODY_INTENSITY_RANGE = (0.34, 0.42), (0.75, 0.95), (0.4, 0.8)
GRADIENT_RANGE = (0.25, 0.45)  # the gradient's rise from the body's centre to its edge, fraction of its intensity
STRUCTURES, STRUCTURE_RADIUS_RANGE, STRUCTURE_CONTRAST_RANGE = (3, 4), (0.02, 0.06), (0.15, 0.35)
HOLES, HOLE_RADIUS_RANGE, HOLE_ASPECT_RANGE, HOLE_DEPTH_RANGE = (1, 2), (0.07, 0.12), (0.5, 0.9), (0.7, 0.95)
HOLE_MAX_A = 0.18
MOVING_RADIUS_RANGE, MOVING_INTENSITY_RANGE = (0.05, 0.09), (0.8, 1.6)
TEXTURED_SPEED_RANGE = (20.0, 150.0)  # deg/rot: texture is the question here, not the fastest motion
TEXTURED_AMPLITUDE_RANGE = {"orbit": (0.04, 0.10), "translation": (0.04, 0.10), "beat": (0.1, 0.3)}
LEVEL_MARGIN = 0.1  # every static pixel lies this far below each moving object's own level
PLACE_TRIES = 50  # tries to place one static inclusion before the whole scene is drawn again


def draw_textured_scene(seed: int, family: str, index: int) -> Scene:
    """Scene ``index`` of ``family`` (``FAMILIES``) for sampler seed ``seed``, from its own generator
    (seed, 29, family, index): units, scanner and noise as `draw_scene`'s, ``layout`` = the family.

    Objects: the body (0; a large static ellipse of intensity 0.4-0.8; ``gradient``: rising
    linearly by 25-45 % of its intensity from its centre to its edge along a random direction), then
    1-2 moving objects nested in it (1..; radius 5-9 % of the FOV; orbit, translation or beat at
    20-150 deg/rot, amplitudes of 4-10 % of the FOV or 10-30 % of the axes), then the family's static
    inclusions, nested in the body: ``structures``: 3-4 small ellipses (semi-axes 2-6 %), intensity
    ±0.15-0.35 over the body's, at least one brighter and one darker; ``holes``: 1-2 lungs (semi-minor
    axis 7-12 %, aspect 0.5-0.9, semi-major axis at most 18 %), 70-95 % of the body's intensity taken away. Every object lies clear of
    the others by ``GAP`` at every time (`layout_ok`); each moving object's intensity makes its own
    level (`Scene.own_levels`: the body's intensity plus half its own) at least ``LEVEL_MARGIN`` above
    every static pixel."""
    if family not in FAMILIES:
        raise ValueError(f"family must be one of {FAMILIES}, got {family!r}")
    rng = np.random.default_rng([seed, 29, FAMILIES.index(family), index])
    units, extent, acquisition, noise_i0 = draw_setting(rng)
    n_moving = int(rng.integers(1, 3))

    def scene_of(objects: list[Ellipse]) -> Scene:
        return Scene(index, units, extent, tuple(objects), family, acquisition, noise_i0)

    for _ in range(MAX_TRIES):
        body = draw_body(rng, family == "gradient")
        contrasts = draw_contrasts(rng, family, body.intensity)
        rise = max([0.0, *contrasts], default=0.0) + (math.hypot(*body.gradient) * body.a)
        low = max(MOVING_INTENSITY_RANGE[0], 2 * (rise + LEVEL_MARGIN))
        objects = [body, *(draw_moving(rng, inner_room(body), float(rng.uniform(low, MOVING_INTENSITY_RANGE[1])))
                           for _ in range(n_moving))]
        if not layout_ok(scene_of(objects), TEXTURED_RADIUS_RANGE):
            continue
        for contrast in contrasts:
            for _ in range(PLACE_TRIES):
                candidate = [*objects, draw_inclusion(rng, family, inner_room(body), contrast)]
                if layout_ok(scene_of(candidate), TEXTURED_RADIUS_RANGE):
                    objects = candidate
                    break
            else:
                break
        else:
            return scene_of(objects)
    raise RuntimeError(f"{family} scene {index} (seed {seed}): no valid layout in {MAX_TRIES} tries")


def draw_textured_scenes(seed: int, n: int, families: tuple[str, ...] = FAMILIES) -> list[Scene]:
    """The first ``n`` scenes of each of ``families``, family by family."""
    return [draw_textured_scene(seed, family, i) for family in families for i in range(n)]


def draw_body(rng: np.random.Generator, graded: bool) -> Ellipse:
    """The static body: semi-axes 34-42 % and 75-95 % of that, inside the FOV circle, intensity 0.4-0.8;
    ``graded``: a linear gradient along a random direction, rising ``GRADIENT_RANGE`` of its intensity
    from the centre to the edge (at most; at the end of its long axis)."""
    a = float(rng.uniform(*BODY_A_RANGE))
    b = a * float(rng.uniform(*BODY_ASPECT_RANGE))
    r, phi = (FOV_RADIUS - a - 0.005) * np.sqrt(rng.random()), rng.uniform(0, 2 * np.pi)
    intensity = float(rng.uniform(*BODY_INTENSITY_RANGE))
    gradient = (0.0, 0.0)
    if graded:
        slope, towards = float(rng.uniform(*GRADIENT_RANGE)) * intensity / a, rng.uniform(0, 2 * np.pi)
        gradient = (float(slope * np.cos(towards)), float(slope * np.sin(towards)))
    return Ellipse(centre=(float(r * np.cos(phi)), float(r * np.sin(phi))), a=a, b=b,
                   angle=float(rng.uniform(0, np.pi)), intensity=intensity, gradient=gradient)


def draw_contrasts(rng: np.random.Generator, family: str, body_intensity: float) -> list[float]:
    """The intensities the family's static inclusions add to the body's: none (gradient); 3-4 of
    ±0.15-0.35, the first brighter, the second darker, the rest either (structures); 1-2 of −70-95 %
    of the body's intensity (holes)."""
    if family == "structures":
        n = int(rng.integers(STRUCTURES[0], STRUCTURES[1] + 1))
        signs = [1.0, -1.0, *rng.choice([-1.0, 1.0], size=n - 2)]
        return [float(s * rng.uniform(*STRUCTURE_CONTRAST_RANGE)) for s in signs]
    if family == "holes":
        n = int(rng.integers(HOLES[0], HOLES[1] + 1))
        return [float(-rng.uniform(*HOLE_DEPTH_RANGE) * body_intensity) for _ in range(n)]
    return []


def draw_moving(rng: np.random.Generator, room: float, intensity: float) -> Ellipse:
    """A moving object nested in object 0, staying within ``room`` of its centre: radius
    ``MOVING_RADIUS_RANGE`` (log-uniform), aspect 0.7-1, orbit | translation | beat
    (``TEXTURED_AMPLITUDE_RANGE``) at ``TEXTURED_SPEED_RANGE`` deg/rot."""
    kind = str(rng.choice(TEXTURED_MOTIONS))
    b = float(np.exp(rng.uniform(*np.log(MOVING_RADIUS_RANGE))))
    direction = float(rng.choice([-1.0, 1.0])) if kind == "orbit" else float(rng.uniform(0, np.pi))
    motion = Motion(kind, float(rng.uniform(*TEXTURED_SPEED_RANGE)),
                    float(rng.uniform(*TEXTURED_AMPLITUDE_RANGE[kind])), direction, float(rng.uniform(0, 2 * np.pi)))
    swing = motion.amplitude if kind in ("orbit", "translation") else 0.0
    grow = 1 + motion.amplitude if kind == "beat" else 1.0
    a = b / float(rng.uniform(0.7, 1.0))
    reach = max(room - swing - a * grow, 0.0)
    r, phi = reach * np.sqrt(rng.random()), rng.uniform(0, 2 * np.pi)
    return Ellipse(centre=(float(r * np.cos(phi)), float(r * np.sin(phi))), a=a, b=b,
                   angle=float(rng.uniform(0, np.pi)), intensity=intensity, motion=motion, parent=0)


def draw_inclusion(rng: np.random.Generator, family: str, room: float, contrast: float) -> Ellipse:
    """A static ellipse nested in object 0, within ``room`` of its centre, adding ``contrast``: a structure
    (semi-axes in ``STRUCTURE_RADIUS_RANGE``) or a hole (``HOLE_RADIUS_RANGE``, ``HOLE_ASPECT_RANGE``)."""
    if family == "holes":
        b = float(rng.uniform(*HOLE_RADIUS_RANGE))
        a = min(b / float(rng.uniform(*HOLE_ASPECT_RANGE)), HOLE_MAX_A)
    else:
        b = float(np.exp(rng.uniform(*np.log(STRUCTURE_RADIUS_RANGE))))
        a = min(b / float(rng.uniform(0.6, 1.0)), STRUCTURE_RADIUS_RANGE[1])
    r, phi = max(room - a, 0.0) * np.sqrt(rng.random()), rng.uniform(0, 2 * np.pi)
    return Ellipse(centre=(float(r * np.cos(phi)), float(r * np.sin(phi))), a=a, b=b,
                   angle=float(rng.uniform(0, np.pi)), intensity=contrast, parent=0)
