"""Ellipses whose every parameter is a `Signal` of time (`EllipseConf`: the objects of the circle,
static and composed scenes, ``phantoms.py``) and the `EllipsePhantom` (``shapes.py``) they make."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from nct.scenes.shapes import EllipseGradients, EllipseParams, EllipsePhantom


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
    axis) and b as fractions of the FOV side, rotation ``angle_deg`` counter-clockwise, intensity
    at its centre (negative: darkens what it lies in, e.g. a lung in a body), and its change per FOV
    side along x and y (``gradient_x``, ``gradient_y``: a graded ellipse, still projected exactly)."""

    x: Signal = field(default_factory=Signal)
    y: Signal = field(default_factory=Signal)
    a: Signal = field(default_factory=lambda: Signal(value=0.1))
    b: Signal = field(default_factory=lambda: Signal(value=0.1))
    angle_deg: Signal = field(default_factory=Signal)
    intensity: Signal = field(default_factory=lambda: Signal(value=1.0))
    gradient_x: Signal = field(default_factory=Signal)
    gradient_y: Signal = field(default_factory=Signal)


ELLIPSE_KEYS = ("x", "y", "a", "b", "angle_deg", "intensity")
GRADIENT_KEYS = ("gradient_x", "gradient_y")


def signal_params(objects: list[EllipseConf]) -> EllipseParams:
    """Ellipse parameters from Signals: τ [T] -> [T, K, 6] (x, y, a, b, angle rad, intensity)."""

    def params(tau: np.ndarray) -> np.ndarray:
        tau = np.atleast_1d(np.asarray(tau, dtype=np.float64))
        out = np.stack([np.stack([getattr(o, k).at(tau) for k in ELLIPSE_KEYS], axis=-1) for o in objects], axis=1)
        out[..., 4] = np.deg2rad(out[..., 4])
        return out

    return params


def signal_gradients(objects: list[EllipseConf]) -> EllipseGradients:
    """Intensity gradients from Signals: τ [T] -> [T, K, 2] (per FOV side along x, y)."""

    def gradients(tau: np.ndarray) -> np.ndarray:
        tau = np.atleast_1d(np.asarray(tau, dtype=np.float64))
        return np.stack([np.stack([getattr(o, k).at(tau) for k in GRADIENT_KEYS], axis=-1) for o in objects], axis=1)

    return gradients


def ellipse_phantom(objects: list[EllipseConf], rotation_time: float) -> EllipsePhantom:
    """The phantom of ``objects``, each an ellipse whose parameters are Signals of time."""
    return EllipsePhantom(signal_params(objects), tuple(float(o.intensity.value) for o in objects), rotation_time,
                          signal_gradients(objects))
