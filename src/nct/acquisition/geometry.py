"""Acquisition geometry: where the ray of every detector bin runs, for parallel and fan beam.

Convention (docs/DATA.md, "Geometry: parallel and fan beam"): at view angle θ let
d = (−sin θ, cos θ) and e = (cos θ, sin θ). Bin i has detector coordinate
u_i = (i − (n_bins − 1)/2)·bin_spacing + detector_offset.

- Parallel beam: the ray of coordinate u is the line {u·e + t·d}.
- Fan beam: the source sits at −source_distance·d. A flat detector is the line
  detector_distance·d + u·e; a curved (equiangular) one an arc about the source where u is the
  arc length at radius source_distance + detector_distance, i.e. fan angle
  γ = u / (source_distance + detector_distance) (flat: γ = atan(u / (source_distance + detector_distance))).

Every ray is a straight line, and every question about rays is answered through its normal form,
that of a parallel ray: the line {σ·e(φ) + t·d(φ)}. A parallel ray has (φ, σ) = (θ, u); a fan ray
at fan angle γ has (φ, σ) = (θ − γ, source_distance·sin γ). The projector, the analytic simulation
and the rebinning for FBP all take rays in this form, so a new geometry only has to say it.

Functions taking ``angles`` work on numpy arrays and on torch tensors alike (same namespace back).
"""

from __future__ import annotations

import math
import sys
from abc import ABC, abstractmethod
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Union

import numpy as np

if TYPE_CHECKING:
    import torch

DETECTOR_SHAPES = ("flat", "curved")
Array = Union[np.ndarray, "torch.Tensor"]  # the ray functions take and give either kind


def _namespace(a):
    """torch for tensors, numpy otherwise: both spell sin, cos, arctan, arcsin, stack alike.
    torch is never imported here: a tensor means the caller already has it (the config schemas,
    which build geometries, stay importable without torch)."""
    torch = sys.modules.get("torch")
    return torch if torch is not None and isinstance(a, torch.Tensor) else np


def _require(ok: bool, rule: str, got: object) -> None:
    if not ok:
        raise ValueError(f"{rule}, got {got!r}")


class Geometry(ABC):
    """A detector of ``n_bins`` bins ``bin_spacing`` apart, centred ``detector_offset`` off the axis."""

    n_bins: int
    bin_spacing: float
    detector_offset: float

    def _check_detector(self) -> None:
        _require(int(self.n_bins) == self.n_bins and self.n_bins >= 1, "n_bins must be an integer >= 1", self.n_bins)
        _require(math.isfinite(self.bin_spacing) and self.bin_spacing > 0, "bin_spacing must be > 0", self.bin_spacing)
        _require(math.isfinite(self.detector_offset), "detector_offset must be a finite number", self.detector_offset)

    @property
    def bin_positions(self) -> np.ndarray:
        """Detector coordinate u of every bin centre: [n_bins] float64."""
        return (np.arange(self.n_bins) - (self.n_bins - 1) / 2) * self.bin_spacing + self.detector_offset

    @property
    def bin_edges(self) -> np.ndarray:
        """Detector coordinates of the bins' edges: [n_bins + 1] float64."""
        return np.append(self.bin_positions, self.bin_positions[-1] + self.bin_spacing) - self.bin_spacing / 2

    @property
    def magnification(self) -> float:
        """Detector coordinate per unit of ray offset σ at the centre of the detector (1 in parallel beam)."""
        return 1.0

    @property
    @abstractmethod
    def is_parallel(self) -> bool:
        """Whether every view's rays are parallel: a view then sees the whole field at its own instant, and
        its moments are the mass's there (a fan view rebinned onto parallel rays mixes instants)."""

    @abstractmethod
    def check_source_outside(self, radius: float, what: str) -> None:
        """Refuse (``ValueError`` naming ``source_distance``) a source within ``radius`` of the axis, ``what``
        that radius is (parallel rays come from no source: nothing to refuse)."""

    @property
    def field_radius(self) -> float:
        """Radius of the disc about the axis that a full turn of views covers: the largest ray offset |σ|."""
        _, sigma = self.lines(np.zeros(1), self.bin_edges)
        return float(np.abs(sigma).max())

    def scaled(self, factor: float) -> "Geometry":
        """The same geometry with every length multiplied by ``factor`` (a change of units)."""
        return replace(self, **{k: v * factor for k, v in self.keys().items() if not isinstance(v, str)})

    @abstractmethod
    def lines(self, angles: Array, u: Array) -> tuple[Array, Array]:
        """Normal form (φ, σ) of the ray at detector coordinate u in the view at angle θ.

        angles [V] (rad), u [B] (numpy or torch, same kind) -> (φ, σ), each broadcastable to [V, B]:
        the ray is the line {σ·e(φ) + t·d(φ)}.
        """

    @abstractmethod
    def locate(self, phi: np.ndarray, sigma: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Inverse of `lines`: the view angle θ and detector coordinate u that measure the line (φ, σ).

        phi, sigma: numpy arrays of one shape -> (θ, u) of that shape. The same line is also
        (φ ± π, −σ), which ``locate`` answers with the view half a turn away.
        """

    def project_points(self, x: np.ndarray, y: np.ndarray, angles: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Where each point lands in each view, and how wide the detector sees it: x, y [P], angles [V]
        -> (u, scale), each [V, P].

        u: the detector coordinate (the convention's projection formula). scale: detector length per
        unit length across the ray at the point (parallel 1; fan: du/dγ over the distance from the
        source), so a point mass m adds m·scale/Δu to the mean line integral of a bin Δu wide holding u.
        """
        s = np.cos(angles)[:, None] * x[None, :] + np.sin(angles)[:, None] * y[None, :]
        r = -np.sin(angles)[:, None] * x[None, :] + np.cos(angles)[:, None] * y[None, :]
        return self._project(s, r)

    @abstractmethod
    def _project(self, s: np.ndarray, r: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """`project_points` of points at s along e and r along d of their view."""

    def rays(self, angles: Array, u: Array | None = None) -> tuple[Array, Array]:
        """A point on every ray and its unit direction: ([V, B, 2], [V, B, 2]) as (x, y).

        The point is the ray's closest approach to the rotation axis; ``u`` [B] defaults to the
        bin centres (numpy or torch, as ``angles`` [V]).
        """
        xp = _namespace(angles)
        if u is None:
            u = self.bin_positions if xp is np else xp.as_tensor(self.bin_positions).to(angles)
        phi, sigma = self.lines(angles, u)
        phi = phi + 0 * sigma  # broadcast both to [V, B]
        cos, sin = xp.cos(phi), xp.sin(phi)
        return xp.stack((sigma * cos, sigma * sin), -1), xp.stack((-sin, cos), -1)

    @abstractmethod
    def keys(self) -> dict[str, float | str]:
        """The sinogram-file keys that describe this geometry (see ``io.py``)."""


@dataclass(frozen=True)
class ParallelGeometry(Geometry):
    """Parallel beam: bin u's ray runs along d through u·e."""

    n_bins: int
    bin_spacing: float
    detector_offset: float = 0.0

    def __post_init__(self) -> None:
        self._check_detector()

    @property
    def is_parallel(self) -> bool:
        return True

    def check_source_outside(self, radius: float, what: str) -> None:
        return None

    def lines(self, angles: Array, u: Array) -> tuple[Array, Array]:
        return angles[:, None], u[None, :]

    def locate(self, phi: np.ndarray, sigma: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return phi, sigma

    def _project(self, s: np.ndarray, r: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return s, np.ones_like(s)

    def keys(self) -> dict[str, float | str]:
        return {"bin_spacing": self.bin_spacing, "detector_offset": self.detector_offset}


@dataclass(frozen=True)
class FanGeometry(Geometry):
    """Fan beam from a point source ``source_distance`` from the axis onto a flat or curved detector
    ``detector_distance`` beyond it (``detector_shape`` "flat" or "curved")."""

    n_bins: int
    bin_spacing: float
    source_distance: float
    detector_distance: float
    detector_shape: str = "flat"
    detector_offset: float = 0.0

    def __post_init__(self) -> None:
        self._check_detector()
        for key in ("source_distance", "detector_distance"):
            value = getattr(self, key)
            _require(math.isfinite(value) and value > 0, f"{key} must be > 0", value)
        _require(self.detector_shape in DETECTOR_SHAPES, "detector_shape must be 'flat' or 'curved'",
                 self.detector_shape)
        reach = float(np.abs(self.bin_edges).max()) / self.source_to_detector
        _require(self.detector_shape == "flat" or reach < math.pi / 2,
                 "detector_offset and n_bins * bin_spacing must keep a curved detector's fan angles within 90 deg",
                 f"{math.degrees(reach):.1f} deg")

    @classmethod
    def covering(cls, radius: float, n_bins: int, source_distance: float, detector_distance: float,
                 detector_shape: str = "flat") -> "FanGeometry":
        """The centred detector whose ``n_bins`` bins just span the fan of rays through the disc of
        ``radius`` about the axis (``ValueError`` naming the key of a bad value)."""
        _require(0 < radius < source_distance, "source_distance must exceed the radius to cover", source_distance)
        probe = cls(1, radius, source_distance, detector_distance, detector_shape)
        width = 2 * float(probe.detector_coordinate(math.asin(radius / source_distance)))
        return cls(n_bins, width / n_bins, source_distance, detector_distance, detector_shape)

    @property
    def source_to_detector(self) -> float:
        """Distance from the source to the detector along the central ray."""
        return self.source_distance + self.detector_distance

    @property
    def magnification(self) -> float:
        return self.source_to_detector / self.source_distance

    @property
    def is_parallel(self) -> bool:
        return False

    def check_source_outside(self, radius: float, what: str) -> None:
        if not self.source_distance > radius:
            raise ValueError(f"source_distance must exceed {what} {radius:.4g} (the source must lie outside the "
                             f"field of view), got {self.source_distance}")

    def fan_angle(self, u: Array) -> Array:
        """Fan angle γ of the ray at detector coordinate u: [B] -> [B] rad (numpy or torch)."""
        ratio = u / self.source_to_detector
        return _namespace(u).arctan(ratio) if self.detector_shape == "flat" else ratio

    def detector_coordinate(self, gamma: Array) -> Array:
        """Inverse of `fan_angle`: the detector coordinate u of fan angle γ, [B] -> [B]."""
        flat = self.detector_shape == "flat"
        return (_namespace(gamma).tan(gamma) if flat else gamma) * self.source_to_detector

    def lines(self, angles: Array, u: Array) -> tuple[Array, Array]:
        gamma = self.fan_angle(u)
        return angles[:, None] - gamma[None, :], (self.source_distance * _namespace(u).sin(gamma))[None, :]

    def locate(self, phi: np.ndarray, sigma: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """As `Geometry.locate`, for lines closer to the axis than the source (|σ| < source_distance)."""
        gamma = np.arcsin(sigma / self.source_distance)
        return phi + gamma, self.detector_coordinate(gamma)

    def _project(self, s: np.ndarray, r: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        along = self.source_distance + r
        gamma = np.arctan2(s, along)
        per_radian = self.source_to_detector / (np.cos(gamma) ** 2 if self.detector_shape == "flat" else 1.0)
        return self.detector_coordinate(gamma), per_radian / np.hypot(s, along)

    def keys(self) -> dict[str, float | str]:
        return {"bin_spacing": self.bin_spacing, "detector_offset": self.detector_offset,
                "source_distance": self.source_distance, "detector_distance": self.detector_distance,
                "detector_shape": self.detector_shape}


def make_geometry(
    n_bins: int,
    bin_spacing: float,
    source_distance: float | None = None,
    detector_distance: float | None = None,
    detector_shape: str | None = None,
    detector_offset: float = 0.0,
) -> ParallelGeometry | FanGeometry:
    """The geometry the sinogram-file keys describe: fan beam exactly when ``source_distance`` is given.

    Raises ``ValueError`` naming the key of a missing or invalid value.
    """
    if source_distance is None:
        for key, value in (("detector_distance", detector_distance), ("detector_shape", detector_shape)):
            _require(value is None, f"{key} is a fan-beam key: it needs source_distance", value)
        return ParallelGeometry(n_bins, bin_spacing, detector_offset)
    _require(detector_distance is not None, "detector_distance must be given with source_distance", None)
    return FanGeometry(n_bins, bin_spacing, source_distance, detector_distance,
                       "flat" if detector_shape is None else detector_shape, detector_offset)
