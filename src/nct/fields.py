"""Neural signed-distance fields g(x, t) = g_E(x) + g_V(x, t) of K objects (paper Sec. IV-A).

Time enters only through a Fourier basis, so the networks see x alone: evaluate them once on the
grid and form g(., t) for any number of times by a product with the basis (see ``Field.sdf``).
"""

from __future__ import annotations

from dataclasses import dataclass

FAMILIES = ("siren",)


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
    f_max: standard deviation of the frequencies omega_i ~ N(0, f_max), in cycles per
        acquisition (time is normalised to t' = (t - t_first) / duration in [0, 1]).
    omega0: SIREN frequency of the first layer (inputs are x scaled to [-1, 1]).
    """

    name: str = "siren"
    family: str = "siren"
    width: int = 64
    depth: int = 3
    temporal_width: int = 64
    temporal_depth: int = 3
    n_terms: int = 32
    f_max: float = 1.5
    omega0: float = 30.0

    def __post_init__(self) -> None:
        require(self.family in FAMILIES, "model.family", f"one of {FAMILIES}", self.family)
        for key in ("width", "depth", "temporal_width", "temporal_depth"):
            require(getattr(self, key) >= 1, f"model.{key}", ">= 1", getattr(self, key))
        require(self.n_terms >= 0, "model.n_terms", ">= 0", self.n_terms)
        require(self.f_max >= 0, "model.f_max", ">= 0", self.f_max)
        require(self.omega0 > 0, "model.omega0", "> 0", self.omega0)
