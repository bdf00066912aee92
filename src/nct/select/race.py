"""The race: every candidate of a run's scene models fitted (InitFit, then SinogramFit) and entered in the
tournament (tournament.py), restarts joining where a fit lost its way."""

from __future__ import annotations

import copy
import logging
from collections.abc import Callable
from dataclasses import replace

import numpy as np
import torch

from nct.errors import DivergenceError
from nct.fields.base import SpaceTimeField
from nct.fields.build import build_field
from nct.fields.conf import RUNGS, ModelConf
from nct.fit.conf import OptimConf, RenderConf
from nct.fit.problem import Problem
from nct.fit.session import Fitted, Session, at_rate, init_fit, sinogram_fit, streams
from nct.init.starts import turned_start
from nct.select.candidates import Candidate, SceneModel, candidates
from nct.select.conf import SelectionConf
from nct.select.scene import SceneSetup
from nct.select.tournament import Tournament, Verdict

log = logging.getLogger(__name__)
RESTART_RATE = 0.5  # a fit whose misfit ends above its start is tried again at this share of its rates
EMPTY = 0.999  # a misfit above this share of an empty image's explains nothing: a field faded to nothing renders
# its sigmoid tails and scores a hair below the empty image (the tiny test's small disc: 1 - 2e-8)


class Race:
    """The fits of one run's candidates, entered in one ``tournament``: each candidate's field (``nets``), its
    InitFit (``started``: misfit, state, generator) and its sinogram fit (``fitted``); ``diverged``: the first
    divergence, the run's error when no candidate finishes."""

    def __init__(self, setups: list[SceneSetup], session: Session, model: ModelConf, seed: int,
                 motion: SelectionConf, optim: OptimConf, render: RenderConf) -> None:
        self.by_model = {s.model: s for s in setups}
        self.session, self.model, self.seed, self.optim, self.render = session, model, seed, optim, render
        self.nets: dict[Candidate, SpaceTimeField] = {}
        self.started: dict[Candidate, tuple[float, dict, np.random.Generator]] = {}
        self.fitted: dict[Candidate, Fitted] = {}
        self.diverged: DivergenceError | None = None
        self.tournament = Tournament(optim.fit_steps, session.check_every if len(setups[0].prob.held_views) else 0,
                                     motion)

    def start(self, cand: Candidate) -> None:
        """Build ``cand``'s field and InitFit it to its start, from the candidate's own streams. An affine field
        whose rigid one was started takes that one's InitFit: InitFit fits a moved template's template alone and
        the affine poses start as the rigid's, so it would fit the same template to the same start."""
        setup, optim = self.by_model[cand.scene], self.optim
        rng, torch_seed = (setup.rng, self.seed) if cand.continues_run else streams(self.seed, cand.key)
        rigid = relaxed(cand)
        with torch.random.fork_rng():  # the field's weights and its InitFit from the candidate's own streams
            torch.manual_seed(torch_seed)
            conf = self.model if cand.f_max is None else replace(self.model, f_max=cand.f_max)
            self.nets[cand] = net = build_field(conf, cand.scene.n_objects, torch.Generator().manual_seed(torch_seed),
                                                cand.rung, setup.prob.span)
            if cand.rung == "affine" and rigid in self.started:
                misfit, state, _ = self.started[rigid]
                net.relax(state)
                self.session.stages[f"{cand.name}_init"] = {"steps": 0, "wall_time_s": 0.0, "misfit": misfit,
                                                            "from": f"{rigid.name}_init"}
            else:
                begin = setup.start(cand.start)
                begin = begin if cand.turning is None else turned_start(setup.prob, begin, cand.turning)
                misfit = init_fit(setup.prob, self.session, net, cand.name, begin, optim.init_steps, optim,
                                  self.render, rng, optim.coarse_size)
        self.started[cand] = misfit, copy.deepcopy(net.state_dict()), rng

    def run(self, pool: list[Candidate]) -> None:
        """InitFit every candidate of ``pool``, then fit them in `fit_order`; a restart joins where a fit lost its
        way."""
        for cand in pool:
            self.start(cand)
        queue = fit_order(pool, {c: misfit for c, (misfit, *_) in self.started.items()})
        while queue:
            cand = queue.pop(0)
            prob = self.by_model[cand.scene].prob
            empty = EMPTY * prob.empty_misfit()
            base = replace(cand, restart=False)
            if cand.restart and self.started[base][0] >= empty:
                self.start(cand)
            elif cand.restart:
                self.nets[cand], self.started[cand] = self.nets[base], self.started[base]
            lost, done = _fit(cand, prob, self.session, self.nets[cand], self.started[cand], self.seed,
                              self.tournament, (self.optim, self.render), empty)
            if isinstance(done, DivergenceError):
                self.diverged = self.diverged or done
            else:
                self.fitted[cand] = done
            if lost and not cand.restart:
                log.warning("%s; a restart at %g of the rates joins the tournament", lost, RESTART_RATE)
                queue.insert(0, replace(cand, restart=True))

    def misfit(self, cand: Candidate) -> float:
        """``cand``'s held-out misfit as the tournament entered it."""
        return next(e.misfit for e in self.tournament.entries if e.candidate == cand)

    def verdict(self) -> Verdict:
        """The tournament's verdict; the first divergence where no candidate finished."""
        if self.diverged is not None and all(e.pruned for e in self.tournament.entries):
            raise self.diverged
        return self.tournament.verdict()


def race(setups: list[SceneSetup], session: Session, model: ModelConf, seed: int, motion: SelectionConf,
         optim: OptimConf, render: RenderConf,
         reserve: Callable[[set[SceneModel], SceneModel], SceneSetup | None] = lambda raced, winner: None,
         suspect: Callable[[float], bool] = lambda misfit: False,
         ) -> tuple[Verdict, dict[Candidate, Fitted], dict[Candidate, SpaceTimeField], SceneSetup]:
    """Fit the candidates of the run's scene models and choose one (select/tournament.py); also the chosen scene
    model's setup. One scene model: every candidate in one round. Several: first each scene model's freest rung
    (the scene models compared at one rung), then the chosen scene model's other candidates. Where the winner's
    held-out misfit is ``suspect`` (worse than FBP's: select/misfits.py), the ``reserve`` scene model
    (select/scene.SceneChoice.reserve) races likewise, and the next while each wins and the winner is still
    suspect. A fit that ends above where it started, or explains the check views no better than an empty image,
    has lost its way (an object fell out of the band, where no gradient reaches it): a restart joins at
    ``RESTART_RATE`` of the rates, from the candidate's InitFit, or from a fresh draw of the field (its own weights
    and InitFit) where that InitFit explained nothing either. A fit that diverges drops out (its restart joins
    likewise); the run fails with its error only when no candidate finishes. Each candidate draws from its own
    streams (session.streams); the paper's field continues its scene model's generator."""
    state = Race(setups, session, model, seed, motion, optim, render)
    if len(setups) == 1:
        state.run(_pool(setups[0], motion, False))
    else:
        _in_rounds(state, setups, motion)
    raced = {s.model for s in setups}
    verdict = state.verdict()
    while suspect(state.misfit(verdict.winner)) and (more := reserve(raced, verdict.winner.scene)) is not None:
        log.info("%s explains the held-out views worse than FBP (misfit %.4g): %s, the next scene model, races too",
                 verdict.winner.name, state.misfit(verdict.winner), more.model.label)
        state.by_model[more.model] = more
        raced.add(more.model)
        _in_rounds(state, [more], motion)
        verdict = state.verdict()
        if verdict.winner.scene != more.model:
            break
    return verdict, state.fitted, state.nets, state.by_model[verdict.winner.scene]


def _in_rounds(state: Race, setups: list[SceneSetup], motion: SelectionConf) -> None:
    """Race ``setups``' scene models: first each one's freest rung (compared with every model raced before at that
    rung), then the other candidates of the one the tournament then chooses, those it has not run yet under
    either name (a run's first model, raced alone, named its candidates without its label)."""
    freest = replace(motion, rungs=[max(motion.rungs, key=RUNGS.index)], band_f_max=None)
    state.run([c for s in setups for c in candidates(freest, s.n_starts, s.prob.span, s.model, 0, True)])
    chosen = state.by_model[state.verdict().winner.scene]
    ran = {replace(c, scene_named=True) for c in state.started}
    state.run([c for c in _pool(chosen, motion, True) if c not in ran])


def fit_order(pool: list[Candidate], started: dict[Candidate, float]) -> list[Candidate]:
    """``pool`` in the order its fits run: from the best-started on (``started``: each candidate's InitFit misfit,
    those of earlier rounds too), a relaxation right after the model it relaxes (`relaxed`), which sets the bound
    that stops it at its first milestone unless it heads for parsimony's. A wider band fits InitFit's FBP frames
    better whatever the motion (a still scene: 0.069 against 0.174, both fits ending at 0.019), so it ran first and
    to its end where it loses (benchmarks/results/generalisation/band_order); an affine fit starts from its rigid one's
    InitFit (`Race.start`), so the two start level and the simpler goes first."""
    def base(cand: Candidate) -> Candidate:
        relaxes = relaxed(cand)
        return relaxes if relaxes in started else cand

    return sorted(pool, key=lambda c: (started[base(c)], int(base(c) != c)))


def relaxed(cand: Candidate) -> Candidate:
    """The candidate ``cand`` relaxes from the same start: a band its free fit, an affine fit its rigid one (the
    affine poses start as the rigid's); itself where it relaxes none."""
    if cand.f_max is not None:
        return replace(cand, f_max=None)
    return replace(cand, rung="rigid") if cand.rung == "affine" else cand


def _pool(setup: SceneSetup, motion: SelectionConf, named: bool) -> list[Candidate]:
    """Every candidate of one scene model (candidates.py), a turning part's included where one is held."""
    turning = 0 if setup.prob.part_orientations is None else setup.model.n_objects
    return candidates(motion, setup.n_starts, setup.prob.span, setup.model, turning, named)


def _fit(cand: Candidate, prob: Problem, session: Session, net: SpaceTimeField,
         started: tuple[float, dict, np.random.Generator], seed: int, tournament: Tournament,
         settings: tuple[OptimConf, RenderConf], empty: float) -> tuple[str | None, Fitted | DivergenceError]:
    """The sinogram fit of ``cand`` from its InitFit (``started``: misfit, state, generator), entered in the
    ``tournament``; returns why it lost its way (None: it did not) and the fit, or the error it diverged with."""
    optim, render = settings
    misfit0, state, rng = started
    net.load_state_dict(state)
    try:
        with torch.random.fork_rng():
            torch.manual_seed(seed if cand.continues_run else streams(seed, cand.key)[1])
            done = sinogram_fit(prob, session, net, cand.name, optim.fit_steps,
                                at_rate(optim, RESTART_RATE if cand.restart else 1.0), render, rng, optim.coarse_size,
                                tournament.stops(cand))
    except DivergenceError as err:  # seen on a GPU: a band candidate at step 100, the free field finished
        session.stages[f"{cand.name}_fit"] = {"verdict": f"diverged: {err}"}
        tournament.record(cand, [], 0, float("inf"), failed=f"diverged: {err}")
        lost = f"{err}; it drops out of the tournament"
        if cand.restart:
            log.warning("%s", lost)
        return lost, err
    entry = tournament.record(cand, done.history, done.steps, done.misfit)
    session.stages[f"{cand.name}_fit"]["verdict"] = entry.pruned or "finished"
    lost = (f"stage {cand.name}_fit: its misfit went from {misfit0:.3g} to {done.misfit:.3g} (an empty "
            f"image's: {empty:.3g})" if entry.pruned is None and (done.misfit > misfit0 or done.misfit >= empty)
            else None)
    return lost, done
