"""One pass of the method: InitFit from each start, then SinogramFit from the best started, with
the start race and the retry (Algorithms 3-4; reconstruct.py runs the passes and chooses among them).
"""

from __future__ import annotations

import copy
import logging
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
import torch

from nct.acquisition.scanner import ImageGrid
from nct.method.conf import LossConf, OptimConf, RenderConf, TrainerConf
from nct.method.fields import Field
from nct.method.race import HeldoutHistory, lost
from nct.method.segment import Segmentation
from nct.method.stages import InitFit, SinogramFit, Views
from nct.method.trainer import (
    HeldoutStop,
    IndexDataModule,
    MinLossStop,
    RunClock,
    Snapshot,
    SnapshotLog,
    run_stage,
)

log = logging.getLogger(__name__)


@dataclass
class Problem:
    """What every pass fits: the grid, losses, views, the SDF-frame times and the view split."""

    grid: ImageGrid
    loss: LossConf
    views: Views
    init_times: torch.Tensor
    fit_views: np.ndarray
    held_views: np.ndarray
    rng: np.random.Generator
    log_dir: Path | None
    logger: str
    trainer: TrainerConf
    check_every: int
    resume: bool
    clock: RunClock
    snapshots: list[Snapshot]
    starts_rng: np.random.Generator


@dataclass(frozen=True)
class Start:
    """Where a pass may start: InitFit's SDF ``targets`` [F, K, H, W] and a(k) ``intensities`` [K]
    (None: the field's own)."""

    targets: np.ndarray
    intensities: np.ndarray | None = None


@dataclass
class _Started:
    """One InitFit of a pass: the field's ``misfit`` on the check views after it, its ``state`` and
    the SinogramFit that would continue it."""

    misfit: float
    state: dict
    fit: SinogramFit


@dataclass
class _Attempt:
    """One SinogramFit of a pass: its stage ``name``, the start it began from, its ``misfit`` on
    the check views at the end (mean of ``losses`` [c]) and the field's ``state`` then."""

    name: str
    start: int
    fit: SinogramFit
    misfit: float
    losses: np.ndarray
    state: dict


def fit_pass(prob: Problem, net: Field, prefix: str, steps: tuple[int, int], optim: OptimConf,
              render: RenderConf, starts: list[Start], stages: dict, lattice: int | None = None,
              stop: Callable[[HeldoutHistory], bool] | None = None,
              start_race: Callable[[HeldoutHistory, HeldoutHistory], dict | None] | None = None,
              ) -> tuple[SinogramFit, np.ndarray, int]:
    """One pass: InitFit to each start's SDF targets, then SinogramFit from the start whose field
    misfits the ``check_views`` least (the leader), the field on a ``lattice``^2 lattice (None: the
    grid's); records the stages in ``stages``. A SinogramFit whose misfit ends above where it started
    is rerun from the InitFit's field at half the rates (``optim.retries``) and the attempt with the
    lowest misfit kept. ``start_race`` (race.py's rule, from the challenger's and the leader's
    held-out histories): each other start's SinogramFit runs too, stops where the rule says it lost,
    and is kept where it ends with a lower misfit than the leader's (None: the leader only).
    ``stop``: a SinogramFit ends after a held-out check where it says so from the held-out history,
    and is not rerun. Returns the fit, its misfit on each check view [c] and the kept start's index."""
    init_steps, fit_steps = steps
    check = torch.from_numpy(check_views(prob))

    def sinogram_fit(rate: float) -> SinogramFit:
        return SinogramFit(net, prob.grid, replace(optim, lr=optim.lr * rate, intensity_lr=optim.intensity_lr * rate),
                           render, prob.loss, prob.views, fit_steps, lattice)

    def init_name(n: int) -> str:
        return prefix + "init" + (f"_start{n}" if n else "")

    def fit_stage(fit: SinogramFit, name: str, start: int, stream: np.random.Generator,
                  stops: Callable[[HeldoutHistory], bool] | None) -> _Attempt:
        stages[name] = run_stage(
            fit, IndexDataModule(prob.fit_views, optim.batch_views, fit_steps, stage_seed(stream), prob.held_views),
            fit_steps, name, prob.trainer, prob.log_dir, prob.logger,
            (MinLossStop(optim.min_loss), *snapshot_log(prob, name), *([HeldoutStop(stops)] if stops else [])),
            prob.check_every, prob.resume)
        losses = fit.view_losses(check)
        return _Attempt(name, start, fit, float(losses.mean()), losses, copy.deepcopy(net.state_dict()))

    weights = copy.deepcopy(net.state_dict())
    tried: list[_Started] = []
    for n, begin in enumerate(starts):
        name = init_name(n)
        net.load_state_dict(weights)
        if begin.intensities is not None:
            net.set_intensities(torch.tensor(begin.intensities, dtype=torch.float32))
        init = InitFit(net, prob.grid, optim, prob.loss, torch.from_numpy(begin.targets), prob.init_times, lattice)
        with torch.random.fork_rng(enabled=n > 0):  # further starts leave every random stream as the first left it
            stages[name] = run_stage(
                init, IndexDataModule(np.arange(prob.init_times.shape[0]), optim.batch_views, init_steps,
                                      stage_seed(prob.starts_rng if n else prob.rng)),
                init_steps, name, prob.trainer, prob.log_dir, prob.logger, snapshot_log(prob, name), resume=prob.resume)
        fit = sinogram_fit(1.0)
        misfit = float(fit.view_losses(check).mean())
        stages[name]["misfit"] = misfit
        tried.append(_Started(misfit, copy.deepcopy(net.state_dict()), fit))
    order = sorted(range(len(tried)), key=lambda n: tried[n].misfit)
    chosen = order[0]
    start, fit = tried[chosen].misfit, tried[chosen].fit
    if len(tried) > 1:
        log.info("%sinit: the leader is candidate %d of the judge's %d best (misfits %s)", prefix, chosen, len(tried),
                 ", ".join(f"{t.misfit:.4g}" for t in tried))
    net.load_state_dict(tried[chosen].state)
    attempts: list[_Attempt] = []
    for attempt in range(optim.retries + 1):
        fit = sinogram_fit(0.5**attempt) if attempt else fit
        done = fit_stage(fit, prefix + "fit" + (f"_retry{attempt}" if attempt else ""), chosen, prob.rng, stop)
        stages[done.name] |= {"misfit_start": start, "misfit_end": done.misfit}
        attempts.append(done)
        if done.misfit <= start or (stop and stop(fit.heldout_history)):
            break
        log.warning("stage %s: the misfit rose from %.3g to %.3g; %s", done.name, start, done.misfit,
                    "rerunning it from its start at half the rates" if attempt < optim.retries
                    else "keeping the best attempt")
        net.load_state_dict(tried[chosen].state)
    leader = min(attempts, key=lambda a: a.misfit)

    def race_leader(history: HeldoutHistory) -> dict | None:
        return start_race(history, leader.fit.heldout_history)

    def beaten(history: HeldoutHistory) -> bool:
        return lost(race_leader(history)) or bool(stop and stop(history))

    for n in order[1:] if start_race and len(prob.held_views) else []:
        net.load_state_dict(tried[n].state)
        challenger = tried[n].fit
        with torch.random.fork_rng():
            done = fit_stage(challenger, prefix + f"fit_start{n}", n, prob.starts_rng, beaten)
        stopped = beaten(challenger.heldout_history)
        stages[done.name] |= {"misfit_start": tried[n].misfit, "misfit_end": done.misfit, "stopped": stopped,
                              "kept": False, "race": race_leader(challenger.heldout_history)}
        log.info("%s: %s", done.name, f"stopped at step {challenger.global_step}: its race was lost" if stopped
                 else f"ended at misfit {done.misfit:.4g} against the leader's {leader.misfit:.4g}")
        if not stopped:
            attempts.append(done)
    kept = min(attempts, key=lambda a: a.misfit)
    for n in range(len(tried)):
        stages[init_name(n)]["kept"] = n == kept.start
    for a in attempts:
        stages[a.name]["kept"] = a is kept
    net.load_state_dict(kept.state)
    return kept.fit, kept.losses, kept.start


def candidate_starts(ranked: list[Segmentation], n_objects: int, most: int) -> list[Segmentation]:
    """The segmentations InitFit tries (``init.starts``), best judged first. One object starts on
    the brightest structure whichever candidate wins, and the fit moves its boundary; with
    several, a candidate can hand an object to the background or split one object in two, and the
    fit cannot create an object no field starts on: there the judge's runners-up are tried too."""
    return ranked[:most] if n_objects > 1 else ranked[:1]


def snapshot_log(prob: Problem, name: str) -> tuple[SnapshotLog, ...]:
    """The snapshot callback of stage ``name``, if the run keeps a trace."""
    every = prob.trainer.snapshot_every_n_steps
    return (SnapshotLog(name, every, prob.snapshots, prob.clock),) if every else ()


def check_views(prob: Problem, most: int = 64) -> np.ndarray:
    """The views that judge whether a fit went astray: the held-out ones, or up to ``most`` fitted ones."""
    if len(prob.held_views):
        return prob.held_views
    return prob.fit_views[np.unique(np.linspace(0, len(prob.fit_views) - 1, most).round().astype(int))]


def held_losses(prob: Problem, checked: np.ndarray) -> np.ndarray:
    """The held-out views' misfits [h] among a pass's ``checked`` ones (``check_views``): none
    when no view is held out (the check then ran on fitted views)."""
    return checked if len(prob.held_views) else np.zeros(0)




def stage_seed(rng: np.random.Generator) -> int:
    """A seed for a stage's own sampler, drawn from the run's generator."""
    return int(rng.integers(2**31 - 1))
