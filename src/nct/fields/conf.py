"""The neural field's settings (config group ``model``): a plain dataclass without torch, so that parsing
a config (``nct.run.config.validate``) stays cheap."""

from __future__ import annotations

from dataclasses import dataclass

from nct.errors import require

FAMILIES = ("siren", "grid")
RUNGS = ("static", "rigid", "affine", "free")  # the motion ladder, simplest first (build.py)


@dataclass
class ModelConf:
    """The neural SDF field (config group ``model``).

    name: the group option. family: "siren" (SIREN static net + SIREN coefficient net) or "grid"
    (explicit grids, see ``GridField``); for the rigid and affine rungs, the template's (fields/moved.py).
    The rung itself is chosen per run by the config group ``motion`` (select/tournament.py).
    pose_terms_per_rotation: rigid, affine: Legendre polynomials over the scan per rotation of it
        (at least 2) in each pose parameter's series in time: few, so the poses stay smooth and
        leave little room for the motion along the rays that no view sees (fields/moved.py).
    width, depth: hidden width and number of hidden layers of the static net g_E (siren).
    temporal_width, temporal_depth: the same for the coefficient net of g_V (siren).
    resolution: cells per side of the finest static grid (grid); levels: grids per part, each
    half the resolution of the one before, summed (grid). temporal_resolution: cells per side of
    the finest grid of Fourier coefficients (grid); motion is smooth, so it can be coarse. A moved
    template spans twice the field of view: on grids of twice these cells per side (grid), or a
    SIREN rendered on resolution points per field of view over its reach, at most resolution a
    side (siren; fields/moved.py).
    carry_resolution: pixels per field of view of the lattice on which a carried free field renders
        its shape, over its object's reach only, at most this many a side (fields/free.py): 64, the
        density and the most points of an uncarried field's first-pass lattice (optim.coarse_size).
        64 pixels a side over the reach instead (1.8x the density on the default circle) took the
        default run 1.43x as long as a whole process and scored within 0.001 on it (seeds 0-4) and
        within 0.004 on the generalisation subset's lone movers, scene088 0.017 lower
        (benchmarks/results/ladder, session 38).
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
    pose_terms_per_rotation: float = 4.0
    width: int = 64
    depth: int = 3
    temporal_width: int = 64
    temporal_depth: int = 3
    n_terms: int = 32
    f_max: float = 0.3
    omega0: float = 10.0
    resolution: int = 128
    levels: int = 3
    temporal_resolution: int = 32
    carry_resolution: int = 64

    def __post_init__(self) -> None:
        require(self.family in FAMILIES, "model.family", f"one of {FAMILIES}", self.family)
        require(self.pose_terms_per_rotation > 0, "model.pose_terms_per_rotation", "> 0", self.pose_terms_per_rotation)
        for key in ("width", "depth", "temporal_width", "temporal_depth", "levels"):
            require(getattr(self, key) >= 1, f"model.{key}", ">= 1", getattr(self, key))
        require(self.n_terms >= 0, "model.n_terms", ">= 0", self.n_terms)
        require(self.f_max >= 0, "model.f_max", ">= 0", self.f_max)
        require(self.omega0 > 0, "model.omega0", "> 0", self.omega0)
        require(self.carry_resolution >= 2, "model.carry_resolution", ">= 2", self.carry_resolution)
        for key in ("resolution", "temporal_resolution") if self.family == "grid" else ():
            require(getattr(self, key) >= 2 ** self.levels, f"model.{key}", f">= 2**model.levels = {2 ** self.levels}",
                    getattr(self, key))
