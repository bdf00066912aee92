"""No more model than the scene needs: choose the number of temporal terms from held-out views.

The ladder lists Fourier term counts M from small to large (0: a static model). Each rung is
fitted (first pass) and scored by its relative sinogram L1 on the held-out views, which no fit
ever sees. Climbing stops at the first rung that does not improve on the one below by more than
``tolerance`` (relative); the one below is chosen. Only the data decide: no truth is read.

Per object, after the first pass, each object's boundary motion is measured (`boundary_motion_px`:
a fitted static object moves a few hundredths of a pixel, a moving one pixels); an object moving
less than ``static_below_px`` (e.g. 0.25) gets a static model for the rest of the run, so a
static body beside a moving vessel holds no temporal terms. This costs no fit. Off by default:
the boundary motion of some moving objects reads as low as 0.17-0.25 px, that of a static one up
to 0.26 px, and freezing such a moving object cost up to 0.036 Dice (benchmarks/results/capacity).

The temporal band: on scans of several rotations the first pass is fitted a second time with a
wider band of frequencies (``band_f_max``), kept only where it cuts the held-out loss to at most
``band_gain`` of the configured band's. An ellipse turning at about 180 deg/rot changes at about
one cycle per rotation, beyond the configured band's largest frequencies; over several rotations
the same angles are seen again at other times, so the held-out views expose a band too narrow.
Most scans do not need it, so the wider fit races the configured one: from ``band_race_at`` of its
steps on, its held-out loss is compared with the configured fit's at the same step at each check,
and the fit stops at the first check where it is above ``band_race_gain`` of it. The race starts
where the occupancy ramp has narrowed to its final width (render.band_anneal, 0.6): before that
the held-out score, taken at the final width, compares fields fitted at another, and a band that
ends well ahead was seen behind at 30 % of its steps (benchmarks/results/generalisation/race). A fit that goes on is not touched, so a kept
band is still the run configured at ``band_f_max``, bit for bit.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Optional

import numpy as np
from skimage.measure import perimeter

from nct.errors import require
from nct.method.race import HeldoutHistory, lost, race


@dataclass
class CapacityConf:
    """How the model's capacity is chosen (config group ``capacity``).

    auto: climb ``ladder`` (else use model.n_terms as configured). ladder: Fourier term counts,
    strictly increasing (0 = static). tolerance: the smallest relative drop of the held-out
    loss that justifies the next rung. static_below_px: an object whose boundary moves less
    than this (pixels, mean over frames) after the first pass is made static (0: never).
    band_f_max: the wider band (model.f_max of the second fit; None: never tried), tried when
    the views span at least ``band_min_rotations`` rotations and it exceeds model.f_max.
    band_gain: the wider band is kept when its held-out loss is at most this share of the
    configured band's. band_race_at: share of the fit's steps from which the wider band's fit
    stops at the first held-out check where its loss is above ``band_race_gain`` x the configured
    fit's at the same step (None: no race, always fitted to the end).
    """

    name: str = "fixed"
    auto: bool = False
    ladder: list[int] = field(default_factory=lambda: [0, 8, 32])
    tolerance: float = 0.05
    static_below_px: float = 0.0
    band_f_max: Optional[float] = 0.5
    band_gain: float = 0.6
    band_min_rotations: float = 1.5
    band_race_at: Optional[float] = 0.6
    band_race_gain: float = 0.9

    def __post_init__(self) -> None:
        require(len(self.ladder) >= 1, "capacity.ladder", "a non-empty list of term counts", self.ladder)
        require(all(m >= 0 for m in self.ladder), "capacity.ladder", "term counts >= 0", self.ladder)
        require(all(a < b for a, b in zip(self.ladder[:-1], self.ladder[1:])), "capacity.ladder",
                "strictly increasing", self.ladder)
        require(0 <= self.tolerance < 1, "capacity.tolerance", "in [0, 1)", self.tolerance)
        require(self.static_below_px >= 0, "capacity.static_below_px", ">= 0", self.static_below_px)
        require(self.band_f_max is None or self.band_f_max > 0, "capacity.band_f_max", "> 0 or null",
                self.band_f_max)
        require(0 < self.band_gain <= 1, "capacity.band_gain", "in (0, 1]", self.band_gain)
        require(self.band_min_rotations >= 0, "capacity.band_min_rotations", ">= 0", self.band_min_rotations)
        require(self.band_race_at is None or 0 < self.band_race_at < 1, "capacity.band_race_at", "in (0, 1) or null",
                self.band_race_at)
        require(self.band_race_gain > 0, "capacity.band_race_gain", "> 0", self.band_race_gain)

    def tries_band(self, f_max: float, rotations: float, n_terms: int, held_out: bool) -> bool:
        """Whether the wider band is tried after a first pass at ``f_max`` with ``n_terms`` terms
        on views spanning ``rotations`` (it is scored on held-out views, so needs some)."""
        return (self.band_f_max is not None and self.band_f_max > f_max and n_terms > 0 and held_out
                and rotations >= self.band_min_rotations)

    def keeps_band(self, configured: float, wider: float) -> bool:
        """Whether the wider band's held-out loss ``wider`` is low enough against ``configured``'s."""
        return wider <= self.band_gain * configured

    def band_race(self, wider: HeldoutHistory, configured: HeldoutHistory, steps: int) -> dict | None:
        """The race (race.py) of the wider fit's held-out history against the configured fit's, from
        ``band_race_at`` of the ``steps`` with ``band_race_gain``."""
        return race(wider, configured, steps, self.band_race_at, self.band_race_gain)

    def band_choice(self, f_max: float, configured: float, wider: float, race: dict | None = None) -> dict:
        """The band kept after first passes at ``f_max`` and at ``band_f_max`` with those held-out
        losses (the wider one where its fit stopped), and why, for metrics.json; ``race``: ``band_race``'s."""
        behind = lost(race)
        kept = self.band_f_max if not behind and self.keeps_band(configured, wider) else f_max
        if behind:
            at, ahead = race["heldout_loss"]
            reason = (f"F_max {self.band_f_max:g}'s fit stopped at step {race['step']}: its held-out loss was "
                      f"{ahead / at:.0%} of F_max {f_max:g}'s at that step ({at:.4g} -> {ahead:.4g}); it goes on when "
                      f"at most {race['gain']:.0%}")
        else:
            reason = (f"F_max {self.band_f_max:g} changed the held-out loss by {wider / configured - 1:+.1%} "
                      f"({configured:.4g} -> {wider:.4g}); kept when it is at most {self.band_gain:.0%} of F_max "
                      f"{f_max:g}'s")
        return {"f_max": [f_max, self.band_f_max], "heldout_loss": [configured, wider], "gain": self.band_gain,
                "kept_f_max": kept, "reason": reason, "race": race}


def band_kept(band: dict | None) -> bool:
    """Whether a ``band_choice`` record (metrics.json -> capacity -> band; None: not tried) kept the wider band."""
    return bool(band and band["kept_f_max"] != band["f_max"][0])


@dataclass(frozen=True)
class Rung:
    """One fitted rung: its term count, held-out loss and parameter count."""

    n_terms: int
    heldout_loss: float
    n_params: int


def next_rung_pays(below: Rung, above: Rung, tolerance: float) -> bool:
    """Whether ``above`` lowers the held-out loss of ``below`` by more than ``tolerance`` (relative)."""
    return above.heldout_loss < (1 - tolerance) * below.heldout_loss


def climb(ladder: list[int], fit: Callable[[int], Rung], tolerance: float) -> tuple[list[Rung], Rung]:
    """Fit rungs of ``ladder`` in turn with ``fit`` until one does not pay; the fitted rungs and the chosen."""
    tried: list[Rung] = []
    for n_terms in ladder:
        tried.append(fit(n_terms))
        if len(tried) > 1 and not next_rung_pays(tried[-2], tried[-1], tolerance):
            return tried, tried[-2]
    return tried, tried[-1]


def explain(tried: list[Rung], chosen: Rung, tolerance: float) -> str:
    """One sentence saying why ``chosen`` was kept."""
    above = [r for r in tried if r.n_terms > chosen.n_terms]
    what = "a static model" if chosen.n_terms == 0 else f"{chosen.n_terms} temporal terms"
    if not above:
        return f"{what}: the top of the ladder (each rung lowered the held-out loss by more than {tolerance:.0%})"
    gain = 1 - above[0].heldout_loss / chosen.heldout_loss
    return (f"{what}: {above[0].n_terms} terms changed the held-out loss by {-gain:+.1%} "
            f"({chosen.heldout_loss:.4g} -> {above[0].heldout_loss:.4g}), not better by more than {tolerance:.0%}")


def boundary_motion_px(masks: np.ndarray) -> np.ndarray:
    """How far each object's boundary moves, in pixels: masks [F, K, H, W] bool -> [K].

    The mean over frames of the pixels where a frame differs from the object's majority mask,
    over the majority mask's perimeter: the mean normal displacement of the boundary (2d/pi for
    a shift by d, d for a growth by d). An object that is empty in every frame scores 0.
    """
    if masks.ndim != 4:
        raise ValueError(f"masks must be [F, K, H, W], got shape {masks.shape}")
    majority = masks.mean(axis=0) > 0.5
    motion = np.zeros(masks.shape[1])
    for k in range(masks.shape[1]):
        boundary = perimeter(majority[k])
        changed = (masks[:, k] ^ majority[k]).sum(axis=(1, 2)).mean()
        motion[k] = changed / boundary if boundary else (np.inf if changed else 0.0)
    return motion


def object_models(motion_px: np.ndarray, static_below_px: float) -> list[dict]:
    """What each object gets, and why, for metrics.json: [{"motion_px", "model"}] per object."""
    return [{"motion_px": float(m), "model": "static" if m < static_below_px else "temporal"} for m in motion_px]
