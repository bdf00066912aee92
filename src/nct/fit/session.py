"""A candidate's two stages: InitFit of a fresh field to a start's SDF frames, then SinogramFit to the views.

Each candidate draws its field's weights and its minibatches from its own random streams, seeded by
(seed, candidate name), so adding or removing a candidate changes no other candidate's fit (but an affine one's,
which starts from its rigid one's InitFit where there is one: select/race.py); the paper's
field from the best judged start (candidate ``free``) continues the run's own streams, so that
``motion=free`` with one start fits exactly as the method did before the ladder.
"""

from __future__ import annotations

import copy
import zlib
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import torch

from nct.fields.base import SpaceTimeField
from nct.fields.sightings import Sightings
from nct.fit.callbacks import HeldoutStop, MinLossStop
from nct.fit.conf import OptimConf, RenderConf, TrainerConf
from nct.fit.problem import HeldoutHistory, Problem
from nct.fit.stages import InitFit, SinogramFit
from nct.fit.trainer import IndexDataModule, RunClock, Snapshot, SnapshotLog, run_stage

if TYPE_CHECKING:
    from nct.init.segmentation import Segmentation


@dataclass(frozen=True)
class Start:
    """Where a fit may start: InitFit's SDF ``targets`` [F, K, H, W] (method units), a(k)
    ``intensities`` [K] (None: the field's own), the ``segmentation`` they came from (None: a
    refinement's own frames), where its objects were ``seen`` (a moved template's first poses;
    None: the field's own) and the static ``background`` [H, W] under them (None: none, or the field's own)."""

    targets: np.ndarray
    intensities: np.ndarray | None = None
    segmentation: Segmentation | None = None
    seen: Sightings | None = None
    background: np.ndarray | None = None


@dataclass
class Session:
    """How a run's stages are run and recorded: Lightning's settings, where stages log and save
    (``log_dir``, ``logger``), the held-out check interval, ``resume``, the run's clock, the snapshots
    of the Dice-against-time trace, and every stage's record (``stages``, by stage name)."""

    trainer: TrainerConf
    log_dir: Path | None
    logger: str
    check_every: int
    resume: bool
    clock: RunClock
    snapshots: list[Snapshot]
    stages: dict


@dataclass
class Fitted:
    """A sinogram fit: its SinogramFit (holding the field), the field's misfit on the check views
    before (``start_misfit``) and after it (``losses`` [c], mean ``misfit``), the held-out ``history``,
    the steps it ran and the field's ``state`` at the end."""

    fit: SinogramFit
    start_misfit: float
    losses: np.ndarray
    misfit: float
    history: HeldoutHistory
    steps: int
    state: dict


def streams(seed: int, name: str) -> tuple[np.random.Generator, int]:
    """A candidate's own sampler generator and torch seed, from the run's ``seed`` and its ``name``."""
    key = zlib.crc32(name.encode())
    return np.random.default_rng([seed, key]), int(np.random.default_rng([seed, key, 1]).integers(2**31 - 1))


def init_fit(prob: Problem, session: Session, net: SpaceTimeField, name: str, start: Start, steps: int, optim: OptimConf,
             render: RenderConf, rng: np.random.Generator, lattice: int | None = None) -> float:
    """InitFit ``net`` to ``start``'s SDF frames for ``steps`` (stage ``<name>_init``) on a ``lattice``^2
    lattice (None: the grid's); returns the field's misfit on the check views after it (``render``'s final band)."""
    if start.intensities is not None:
        net.set_intensities(torch.tensor(start.intensities, dtype=torch.float32))
    if start.seen is not None:
        net.start_motion(start.seen)
    if start.background is not None:
        net.set_background(torch.from_numpy(start.background))
    init = InitFit(net, prob.grid, optim, prob.loss, torch.from_numpy(start.targets), prob.init_times, lattice)
    record = run_stage(
        init, IndexDataModule(np.arange(prob.init_times.shape[0]), optim.batch_views, steps, _seed(rng)),
        steps, f"{name}_init", session.trainer, session.log_dir, session.logger,
        _snapshot_log(session, f"{name}_init"), resume=session.resume)
    misfit = float(SinogramFit(net, prob.grid, optim, render, prob.loss, prob.views, 1, lattice)
                   .view_losses(torch.from_numpy(prob.check_views())).mean())
    session.stages[f"{name}_init"] = record | {"misfit": misfit}
    return misfit


def sinogram_fit(prob: Problem, session: Session, net: SpaceTimeField, name: str, steps: int, optim: OptimConf,
                 render: RenderConf, rng: np.random.Generator, lattice: int | None = None,
                 stop: Callable[[HeldoutHistory], bool] | None = None) -> Fitted:
    """SinogramFit ``net`` to the fitted views for ``steps`` (stage ``<name>_fit``); it ends after a
    held-out check where ``stop`` says so from its history. Recorded in ``session.stages``."""
    check = torch.from_numpy(prob.check_views())
    fit = SinogramFit(net, prob.grid, optim, render, prob.loss, prob.views, steps, lattice)
    start_misfit = float(fit.view_losses(check).mean())
    record = run_stage(
        fit, IndexDataModule(prob.fit_views, optim.batch_views, steps, _seed(rng), prob.held_views),
        steps, f"{name}_fit", session.trainer, session.log_dir, session.logger,
        (MinLossStop(optim.min_loss), *_snapshot_log(session, f"{name}_fit"), *([HeldoutStop(stop)] if stop else [])),
        session.check_every, session.resume)
    losses = fit.view_losses(check)
    session.stages[f"{name}_fit"] = record | {"misfit_start": start_misfit, "misfit_end": float(losses.mean())}
    return Fitted(fit, start_misfit, losses, float(losses.mean()), list(fit.heldout_history), int(record["steps"]),
                  copy.deepcopy(net.state_dict()))


def at_rate(optim: OptimConf, rate: float) -> OptimConf:
    """``optim`` with its learning rates scaled by ``rate`` (a restart's)."""
    return replace(optim, lr=optim.lr * rate, intensity_lr=optim.intensity_lr * rate)


def _snapshot_log(session: Session, name: str) -> tuple[SnapshotLog, ...]:
    """The snapshot callback of stage ``name``, if the run keeps a trace."""
    every = session.trainer.callbacks.snapshot_every_n_steps
    return (SnapshotLog(name, every, session.snapshots, session.clock),) if every else ()


def _seed(rng: np.random.Generator) -> int:
    """A seed for a stage's own sampler, drawn from the candidate's generator."""
    return int(rng.integers(2**31 - 1))
