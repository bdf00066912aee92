"""Neural signed-distance fields g(x, t) = g_E(x) + g_V(x, t) of K objects (paper Sec. IV-A).

Time enters only through a Fourier basis, so the networks see x alone: evaluate them once on the
grid and form g(., t) for any number of times by a product with the basis (see ``Field.sdf``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import torch
from torch import Tensor, nn

FAMILIES = ("siren",)
HIDDEN_OMEGA = 30.0  # SIREN's frequency for hidden layers (Sitzmann et al.); its init compensates


def require(ok: bool, key: str, expected: str, got: object) -> None:
    """Raise ValueError naming the config ``key`` and what was ``expected`` unless ``ok``."""
    if not ok:
        raise ValueError(f"{key} must be {expected}, got {got!r}")


@dataclass
class ModelConf:
    """The neural SDF field (config group ``model``).

    name: the group option. family: "siren" (SIREN static net + SIREN coefficient net).
    width, depth: hidden width and number of hidden layers of the static net g_E.
    temporal_width, temporal_depth: the same for the coefficient net of g_V.
    n_terms: M, Fourier terms of g_V; 0 gives a static model (no temporal terms).
    f_max: standard deviation of the frequencies omega_i ~ N(0, f_max) in cycles per gantry
        rotation (time is measured in rotations from the first view). Keep it well below 1: a
        motion that turns with the gantry (1 cycle per rotation for a shift, m for an m-fold shape
        change) leaves every view unchanged, so a basis reaching there makes the fit ambiguous.
    omega0: SIREN frequency of the first layer (inputs are x scaled to [-1, 1]); low values give
        smooth fields, which is what an SDF is.
    """

    name: str = "siren"
    family: str = "siren"
    width: int = 64
    depth: int = 3
    temporal_width: int = 64
    temporal_depth: int = 3
    n_terms: int = 32
    f_max: float = 0.3
    omega0: float = 10.0

    def __post_init__(self) -> None:
        require(self.family in FAMILIES, "model.family", f"one of {FAMILIES}", self.family)
        for key in ("width", "depth", "temporal_width", "temporal_depth"):
            require(getattr(self, key) >= 1, f"model.{key}", ">= 1", getattr(self, key))
        require(self.n_terms >= 0, "model.n_terms", ">= 0", self.n_terms)
        require(self.f_max >= 0, "model.f_max", ">= 0", self.f_max)
        require(self.omega0 > 0, "model.omega0", "> 0", self.omega0)


class Siren(nn.Module):
    """Sine-activated MLP (Sitzmann et al. 2020): [P, in] -> [P, out]; the last layer is linear."""

    def __init__(self, n_in: int, width: int, depth: int, n_out: int, omega0: float) -> None:
        super().__init__()
        sizes = [n_in] + [width] * depth
        self.hidden = nn.ModuleList(nn.Linear(a, b) for a, b in zip(sizes[:-1], sizes[1:]))
        self.out = nn.Linear(width, n_out)
        self.omegas = [omega0] + [HIDDEN_OMEGA] * (depth - 1)
        with torch.no_grad():
            for i, layer in enumerate(self.hidden):
                bound = 1 / layer.in_features if i == 0 else math.sqrt(6 / layer.in_features) / HIDDEN_OMEGA
                layer.weight.uniform_(-bound, bound)
            bound = math.sqrt(6 / width) / HIDDEN_OMEGA
            self.out.weight.uniform_(-bound, bound)

    def forward(self, x: Tensor) -> Tensor:
        for omega, layer in zip(self.omegas, self.hidden):
            x = torch.sin(omega * layer(x))
        return self.out(x)


@dataclass
class Coefficients:
    """The field's networks evaluated at P points: static [K, P], temporal [2M, K, P] (None if M = 0)."""

    static: Tensor
    temporal: Tensor | None


class Field(nn.Module):
    """g(x, t) = g_E(x) + (1/M) sum_i A_i(x) sin(2 pi w_i t) + B_i(x) cos(2 pi w_i t), K outputs.

    x: points scaled to [-1, 1] (x right, y up); t: time in gantry rotations. The frequencies
    w_i ~ N(0, f_max) are drawn once from ``generator``.
    """

    def __init__(self, conf: ModelConf, n_objects: int, generator: torch.Generator) -> None:
        super().__init__()
        self.n_objects = n_objects
        self.n_terms = conf.n_terms
        self.static = Siren(2, conf.width, conf.depth, n_objects, conf.omega0)
        self.temporal = (
            Siren(2, conf.temporal_width, conf.temporal_depth, 2 * conf.n_terms * n_objects, conf.omega0)
            if conf.n_terms
            else None
        )
        self.register_buffer("omega", torch.randn(conf.n_terms, generator=generator) * conf.f_max)

    def coefficients(self, xy: Tensor) -> Coefficients:
        """Evaluate both networks once at points ``xy`` [P, 2]; time enters later by ``sdf``."""
        static = self.static(xy).T
        if self.temporal is None:
            return Coefficients(static, None)
        return Coefficients(static, self.temporal(xy).T.reshape(2 * self.n_terms, self.n_objects, -1))

    def basis(self, t: Tensor) -> Tensor:
        """The Fourier basis with the 1/M factor: t [T] -> [T, 2M] (sines, then cosines)."""
        phase = 2 * math.pi * t[:, None] * self.omega[None, :]
        return torch.cat([torch.sin(phase), torch.cos(phase)], dim=1) / self.n_terms

    def basis_rate(self, t: Tensor) -> Tensor:
        """d basis / dt: t [T] -> [T, 2M]."""
        rate = 2 * math.pi * self.omega[None, :]
        phase = rate * t[:, None]
        return torch.cat([rate * torch.cos(phase), -rate * torch.sin(phase)], dim=1) / self.n_terms

    def sdf(self, c: Coefficients, t: Tensor) -> Tensor:
        """g at times t [T] from coefficients at P points: [T, K, P]."""
        static = c.static.expand(t.shape[0], -1, -1)
        if c.temporal is None:
            return static
        return static + torch.einsum("tm,mkp->tkp", self.basis(t), c.temporal)

    def sdf_rate(self, c: Coefficients, t: Tensor) -> Tensor:
        """dg/dt (per rotation) at times t [T]: [T, K, P]; zero for a static model."""
        if c.temporal is None:
            return c.static.new_zeros(t.shape[0], *c.static.shape)
        return torch.einsum("tm,mkp->tkp", self.basis_rate(t), c.temporal)

    def describe(self) -> dict:
        """Capacity summary: family, sizes, parameter count, frequencies."""
        return {
            "n_params": sum(p.numel() for p in self.parameters()),
            "n_terms": self.n_terms,
            "static": self.temporal is None,
            "omega_abs_max": float(self.omega.abs().max()) if self.n_terms else 0.0,
        }


def build_field(conf: ModelConf, n_objects: int, generator: torch.Generator) -> Field:
    """The field of ``conf.family`` for ``n_objects`` objects."""
    if n_objects < 1:
        raise ValueError(f"n_objects must be >= 1, got {n_objects}")
    return Field(conf, n_objects, generator)
