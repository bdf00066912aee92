"""One tournament for every choice the method makes from data (motion rung, temporal band, start, restart).

Candidates are fitted one after another (race.fit_order) and scored on the held-out views, which
no fit sees. Successive halving, run sequentially (as Optuna's pruner does): the milestones of the
schedule (milestones) are at ``first_budget`` x steps, twice that, ... ; at each milestone a fit stops where,
were the misfits to stay as they stand there, parsimony would not choose it: above (1 + ``tolerance``) x
a freer model's misfit, above a candidate's of its own model, or above a simpler model's over
(1 + ``tolerance``), each by more than ``milestone_margin`` (a near tie so early is no forecast); another
scene model's only from ``scene_budget`` x steps on (more objects start further from their end). So a fit
that cannot win costs only the steps to its first losing milestone. Parsimony then picks the model: the
simplest whose best finished candidate (over its starts and restarts) is within (1 + ``tolerance``) of
the best, and that candidate wins. The table
of every candidate (``Verdict.rows``) is written as selection.csv. No truth is read.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

from nct.fit.problem import HeldoutHistory
from nct.select.candidates import Candidate, SceneModel
from nct.select.conf import SelectionConf


@dataclass(frozen=True)
class Row:
    """One line of selection.csv: a candidate's model, how far it ran, its held-out misfit and its verdict."""

    candidate: str
    n_objects: int
    background: str
    rung: str
    f_max: float | None
    start: int
    turning: int | None
    restart: bool
    steps: int
    heldout_misfit: float
    verdict: str


@dataclass
class Entry:
    """A fitted candidate: the steps it ran, its held-out ``history`` and its final ``misfit``
    and ``pruned``: why it stopped at a milestone (None: it finished)."""

    candidate: Candidate
    steps: int
    history: HeldoutHistory
    misfit: float
    pruned: str | None = None


@dataclass(frozen=True)
class Verdict:
    """The winner and one row per candidate for selection.csv."""

    winner: Candidate
    rows: list[Row]
    reason: str


class Tournament:
    """Sequential successive halving over fits of ``steps`` steps whose held-out views are scored
    every ``check_every`` steps (the milestones fall on those checks; 0: none), then parsimony."""

    def __init__(self, steps: int, check_every: int, conf: SelectionConf) -> None:
        self.steps, self.conf = steps, conf
        self.entries: list[Entry] = []
        self.milestones: list[int] = []
        budget = conf.first_budget * steps
        while check_every > 0 and budget < steps:
            step = math.ceil(budget / check_every) * check_every
            if step < steps and step not in self.milestones:
                self.milestones.append(step)
            budget *= 2

    def _at(self, history: HeldoutHistory, step: int) -> float | None:
        """The misfit of the last check at or before ``step`` (None: no check yet)."""
        due = [loss for at, loss in history if at <= step]
        return due[-1] if due else None

    def to_win_at(self, candidate: Candidate, step: int) -> float:
        """The misfit ``candidate`` must not exceed at ``step`` to be chosen were the recorded candidates'
        misfits there final (inf: none reached it): parsimony's bound against each comparable one."""
        bounds = []
        for e in self.entries:
            seen = self._at(e.history, step) if e.steps >= step else None
            factor = self._factor(candidate, e.candidate, step)
            if seen is not None and factor is not None:
                bounds.append(seen * factor)
        return min(bounds, default=math.inf)

    def _factor(self, candidate: Candidate, other: Candidate, step: int) -> float | None:
        """How far above ``other``'s misfit ``candidate``'s may lie at ``step`` and still win (parsimony): within a
        scene model by the rungs' ``tolerance``, between scene models (at the same rung and band, from
        ``scene_budget`` x steps on) by ``scene_tolerance``; None where the two are not compared (other scene model
        and rung, or too early)."""
        if other.scene == candidate.scene:
            a, b, tolerance = other.simplicity, candidate.simplicity, self.conf.tolerance
        elif other.simplicity == candidate.simplicity and step >= self.conf.scene_budget * self.steps:
            a, b, tolerance = other.scene.simplicity, candidate.scene.simplicity, self.conf.scene_tolerance
        else:
            return None
        return (1 + tolerance) ** ((a > b) - (a < b))

    def verdict_at(self, candidate: Candidate, history: HeldoutHistory) -> str | None:
        """Why ``candidate``'s fit with this ``history`` stops now (None: it goes on): its latest check is a
        milestone where its misfit is above (1 + ``milestone_margin``) x what it would need to win (``to_win_at``)."""
        if not history:
            return None
        step, loss = history[-1]
        if step not in self.milestones:
            return None
        bound = self.to_win_at(candidate, step)
        if loss > (1 + self.conf.milestone_margin) * bound:
            behind = f"{loss / bound - 1:.1%}" if bound > 0 else "far"  # bound 0: another fit explained every view
            return f"stopped at step {step}: held-out misfit {loss:.4g}, {behind} above the {bound:.4g} it needed to win"
        return None

    def stops(self, candidate: Candidate) -> Callable[[HeldoutHistory], bool]:
        """The rule for ``candidate``'s fit (a HeldoutStop callback's): stop where ``verdict_at`` says."""
        return lambda history: self.verdict_at(candidate, history) is not None

    def record(self, candidate: Candidate, history: HeldoutHistory, steps: int, misfit: float,
               failed: str | None = None) -> Entry:
        """Enter a fitted candidate; one that stopped before ``steps`` is pruned (its misfit kept for the table),
        one whose fit ``failed`` (why, e.g. it diverged) is pruned for that reason."""
        pruned = failed or (self.verdict_at(candidate, history) if steps < self.steps else None)
        entry = Entry(candidate, steps, list(history), misfit, pruned)
        self.entries.append(entry)
        return entry

    def verdict(self) -> Verdict:
        """Parsimony among the finished candidates, the scene model first: the simplest scene model whose best
        misfit is within (1 + scene_tolerance) of the best, then within it the simplest rung within (1 + tolerance)
        of its best, and that rung's best candidate."""
        finished = [e for e in self.entries if e.pruned is None and math.isfinite(e.misfit)]
        if not finished:
            raise ValueError("no candidate finished its fit")
        best_entry = min(finished, key=lambda e: e.misfit)
        scenes = {e.candidate.scene: min(f.misfit for f in finished if f.candidate.scene == e.candidate.scene)
                  for e in finished}
        scene = min((s for s, m in scenes.items() if m <= (1 + self.conf.scene_tolerance) * best_entry.misfit),
                    key=lambda s: s.simplicity)
        ours = [e for e in finished if e.candidate.scene == scene]
        bound = (1 + self.conf.tolerance) * scenes[scene]
        model = min(e.candidate.simplicity for e in ours if e.misfit <= bound)
        winner = min((e for e in ours if e.candidate.simplicity == model), key=lambda e: e.misfit)
        rows = [self._row(e, winner, bound, scenes) for e in self.entries]
        ours_best = min(ours, key=lambda e: e.misfit)
        return Verdict(winner.candidate, rows, self._reason(winner, ours_best, best_entry, len(scenes) > 1))

    def _row(self, e: Entry, winner: Entry, bound: float, scenes: dict[SceneModel, float]) -> Row:
        """``e``'s line of the table, its verdict against the ``winner`` (``bound``: the winner's scene model's
        rung tolerance bound; ``scenes``: each scene model's best misfit)."""
        chosen = winner.candidate.scene
        if e is winner:
            why = "winner"
        elif e.pruned:
            why = e.pruned
        elif e.candidate.scene != chosen:
            why = (f"scene model {e.candidate.scene.label}: its best held-out misfit {scenes[e.candidate.scene]:.4g} "
                   f"against {scenes[chosen]:.4g} of {chosen.label}, "
                   + ("the simpler" if chosen.simplicity < e.candidate.scene.simplicity else "the better"))
        elif e.candidate.simplicity == winner.candidate.simplicity:
            why = f"held-out misfit {e.misfit / winner.misfit - 1:+.1%} against {winner.candidate.name}, of the same model"
        elif e.misfit <= bound:
            why = f"within {self.conf.tolerance:.0%} of the best; {winner.candidate.name} is simpler"
        else:
            why = f"held-out misfit {e.misfit / scenes[chosen] - 1:+.1%} against the best"
        c = e.candidate
        return Row(c.name, c.scene.n_objects, c.scene.background, c.rung, c.f_max, c.start, c.turning, c.restart,
                   e.steps, e.misfit, why)

    def _reason(self, winner: Entry, ours: Entry, best: Entry, scenes: bool) -> str:
        """Why ``winner`` won, in a line: against ``ours``, its scene model's best, and where several ``scenes``
        were compared, the ``best`` of all."""
        reason = (f"{winner.candidate.name}: the best held-out misfit ({ours.misfit:.4g})" if winner is ours else
                  f"{winner.candidate.name}: the simplest within {self.conf.tolerance:.0%} of the best "
                  f"({winner.misfit:.4g} against {ours.candidate.name}'s {ours.misfit:.4g})")
        if scenes:
            reason += (f"; scene model {winner.candidate.scene.label}, the simplest within "
                       f"{self.conf.scene_tolerance:.0%} of the best ({best.candidate.name}'s {best.misfit:.4g})")
        return reason
