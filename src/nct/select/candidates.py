"""The tournament's typed candidates: a scene model, a motion rung, a start, a band, a restart. A candidate's
name and random streams are made from its fields; nothing reads a name back."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

from nct.fields.conf import RUNGS

BACKGROUND_ORDER = ("none", "image")  # the scene models' backgrounds, simplest first

if TYPE_CHECKING:
    from nct.select.conf import SelectionConf


@dataclass(frozen=True)
class SceneModel:
    """What a candidate takes the scene to be: ``n_objects`` objects of distinct intensity over the
    ``background`` ("none": empty; "image": a static image under them, the objects then its moving parts)."""

    n_objects: int
    background: str = "none"

    @property
    def simplicity(self) -> tuple[int, int]:
        """Lower is simpler: no background before a static image, then fewer objects."""
        return BACKGROUND_ORDER.index(self.background), self.n_objects

    @property
    def label(self) -> str:
        """The model in a few characters, e.g. ``k2_image``."""
        return f"k{self.n_objects}_{self.background}"


@dataclass(frozen=True)
class Candidate:
    """One choice in the tournament: the ``scene`` model, its motion ``rung``, the index of the judged
    ``start`` it begins from, its field's temporal band ``f_max`` (None: model.f_max), the object its free
    field turns with a turning part's axis read off the views (``turning``; None: none, fit/problem.py) and
    whether it is a ``restart`` (at a lower rate, after the fit lost its way). ``scene_named``: the run
    compares scene models, so its stages carry the scene's label."""

    scene: SceneModel
    rung: str
    start: int = 0
    f_max: float | None = None
    turning: int | None = None
    restart: bool = False
    scene_named: bool = False

    @property
    def key(self) -> str:
        """The candidate within its scene model, e.g. ``free_band_start1_restart``: its random streams derive
        from it (fitting.streams), so a scene model's candidates fit as they would were it the only one."""
        if self.turning is not None:
            key = f"free_turn{self.turning}"
        else:
            key = ("free_band" if self.f_max is not None else self.rung) + (f"_start{self.start}" if self.start else "")
        return key + ("_restart" if self.restart else "")

    @property
    def name(self) -> str:
        """A unique name within the run: the names of its stages (checkpoints, records) begin with it."""
        return f"{self.scene.label}_{self.key}" if self.scene_named else self.key

    @property
    def simplicity(self) -> tuple[int, ...]:
        """Lower is simpler: the ladder's order, then the band."""
        return RUNGS.index(self.rung), int(self.f_max is not None)

    @property
    def continues_run(self) -> bool:
        """The paper's field from the best judged start: it continues the run's own random streams, so that
        ``motion=free`` with one start fits exactly as the method did before the ladder."""
        return self.rung == "free" and self.start == 0 and self.f_max is None and self.turning is None \
            and not self.restart



def candidates(motion: SelectionConf, n_starts: int, span: float, scene: SceneModel, turning: int = 0,
               scene_named: bool = False) -> list[Candidate]:
    """The candidates of one ``scene`` model: each rung of ``motion.rungs`` from each of ``n_starts`` judged starts, and on a scan of
    ``span`` >= ``motion.band_min_rotations`` rotations the free rung at ``motion.band_f_max`` too; simpler
    models, then better judged starts, first. Where one of ``turning`` objects turns with a part's axis read
    off the views (fit/problem.py), the free rung from the best judged start turning each of them in turn: the
    same model, which object turns the held-out views tell."""
    bands: list[tuple[str, float | None]] = [(rung, None) for rung in motion.rungs]
    if "free" in motion.rungs and motion.band_f_max is not None and span >= motion.band_min_rotations:
        bands.append(("free", motion.band_f_max))
    pool = [Candidate(scene, rung, n, f_max, scene_named=scene_named)
            for rung, f_max in bands for n in range(n_starts)]
    if "free" not in motion.rungs:
        return pool
    return pool + [Candidate(scene, "free", turning=k, scene_named=scene_named) for k in range(turning)]
