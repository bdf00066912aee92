"""NeuralCT end to end: a sinogram in, intensity frames out, never reading the truth.

The way through runs downwards: prepare (units, views, FBP: fit/problem.py) -> initialise (starts:
init/starts.py) -> fit and select (each candidate, a motion rung from a start, fitted and scored on the
held-out views in one tournament: fit/session.py, select/tournament.py) -> refine the winner -> frames.
"""

from __future__ import annotations

import copy
import functools
import logging
import math
from collections.abc import Callable
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path

import lightning as L
import numpy as np
import torch

from nct.acquisition.scanner import ImageGrid
from nct.acquisition.sinogram import Sinogram
from nct.fields.base import SpaceTimeField
from nct.fields.build import FieldSpec
from nct.fields.conf import ModelConf
from nct.fit.conf import (
    LOGGERS,
    HeldoutConf,
    LossConf,
    OptimConf,
    RenderConf,
    TrainerConf,
)
from nct.fit.problem import Problem, heldout_standard_error
from nct.fit.render import intensity
from nct.fit.session import Session, Start, init_fit, sinogram_fit, streams
from nct.fit.stages import FieldStage, SinogramFit
from nct.fit.trainer import RunClock, snapshot
from nct.fit.units import Units
from nct.init.conf import BackgroundConf, InitConf
from nct.init.sdf import binarise, masks_to_sdf
from nct.method.fitted import FittedField, acquisition_span
from nct.physics.conf import FBPConf
from nct.select.candidates import Candidate
from nct.select.conf import SelectionConf
from nct.select.misfits import HeldoutMisfits, heldout_misfits
from nct.select.race import race
from nct.select.scene import Preparation, SceneSetup, scene_setups
from nct.select.stillness import Ladder, ladder
from nct.select.tournament import Verdict

log = logging.getLogger(__name__)



@dataclass(frozen=True)
class TracePoint:
    """The run's frames [F, H, W] (data units) as they stood after ``step`` steps of stage ``stage``,
    ``seconds`` after ``reconstruct`` began (snapshot copies not counted)."""

    stage: str
    step: int
    seconds: float
    frames: np.ndarray


@dataclass
class NCTResult:
    """What ``reconstruct`` returns.

    frames: [F, H, W] float32 intensity b + sum_k a(k) zeta_k (b: the static background, if any); sdf: [F, K, H, W] float32 (physical
    units, positive inside); intensities: [K] a(k); heldout_loss: relative sinogram L1 on the
    held-out views (NaN if none) and heldout_se its standard error; stages: per stage {steps,
    losses, wall_time_s, ...}; model: the winner's field (motion rung, family, parameters);
    selection: the tournament's verdict (winner, reason, one row per candidate: selection.csv);
    init: the starts (init/segmentation.py's route, levels), the units, in the data's, and the degrees of view angle a
    held axis leaves its object's own frame seen over (fit/problem.py; None: none held); trace: snapshots;
    background: the static image [H, W] float32 under the objects (``background=image``; None: none);
    fitted: the winner's field, moved to the CPU, and what rebuilds and renders it (method/fitted.py);
    misfits: its held-out misfit beside FBP's and the noise's (select/misfits.py, computed once for the race and the
    run's warnings; None without held-out views).
    """

    frames: np.ndarray
    sdf: np.ndarray
    intensities: np.ndarray
    heldout_loss: float
    heldout_se: float = float("nan")
    stages: dict = field(default_factory=dict)
    model: dict = field(default_factory=dict)
    selection: dict = field(default_factory=dict)
    init: dict = field(default_factory=dict)
    trace: list[TracePoint] = field(default_factory=list)
    background: np.ndarray | None = None
    fitted: FittedField | None = None
    misfits: HeldoutMisfits | None = None


@torch.no_grad()
def field_frames(fit: FieldStage, times: torch.Tensor, chunk: int = 32) -> np.ndarray:
    """Algorithm 5: the field sampled on the grid at ``times`` [T] (rotations): [T, K, H, W] f32."""
    return np.concatenate([fit.grid_sdf(part.to(fit.device)).cpu().numpy() for part in times.split(chunk)])


def reconstruct(
    sino: Sinogram,
    grid: ImageGrid,
    frame_times: np.ndarray,
    model: ModelConf,
    loss: LossConf,
    trainer: TrainerConf,
    seed: int,
    log_dir: Path | None = None,
    logger: str = "tensorboard",
    fbp_filter: str = "ramp",
    fbp_window_deg: float = 180.0,
    n_objects: int | None = None,
    motion: SelectionConf | None = None,
    optim: OptimConf | None = None,
    render: RenderConf | None = None,
    init: InitConf | None = None,
    heldout: HeldoutConf | None = None,
    background: BackgroundConf | None = None,
    resume: bool = False,
    lap: Callable[[str], None] = lambda phase: None,
) -> NCTResult:
    """Reconstruct intensity frames at ``frame_times`` [F] (s) on ``grid``; never reads ``sino.truth``.

    Fitted in the method's units (fit/units.py), returned in the data's. Every candidate (a scene model:
    ``n_objects`` and ``background``, chosen from the data where None or auto (select/scene.py); ``motion.rungs``
    x the starts; the static rung or the moving ones, as the views say: select/stillness.py) is fitted and scored
    on the held-out views in one tournament (select/race.py); the winner is
    refined (``optim.refine``). ``background=image``: a static image under the objects (init/background.py).
    ``resume``: stages that finished before in ``log_dir`` are loaded from their checkpoints.
    ``lap``: the caller's stopwatch, told as ``initialisation`` and ``tournament`` end. A winner whose held-out
    misfit beyond the noise is above ``motion.fbp_ratio`` x FBP's races the next scene model by price too.
    """
    motion, optim, render = motion or SelectionConf(), optim or OptimConf(), render or RenderConf()
    init, heldout, background = init or InitConf(), heldout or HeldoutConf(), background or BackgroundConf()
    _check(n_objects, logger)
    session = Session(trainer, log_dir, logger, heldout.check_every, resume, RunClock(), [], {})
    L.seed_everything(seed, verbose=False)
    prepared = Preparation(sino, grid, loss, init, heldout, background, (fbp_filter, fbp_window_deg))
    choice = scene_setups(prepared, n_objects, seed)
    lap("initialisation")
    fbp = FBPConf(fbp_filter, fbp_window_deg)
    references = functools.cache(lambda: heldout_misfits(sino, grid, 0.0, heldout, fbp))  # the data's alone: once
    rungs = ladder(sino, motion)
    verdict, fitted, nets, chosen = race(choice.setups, session, model, seed, rungs.motion, optim, render,
                                         choice.reserve, _worse_than_fbp(references, motion.fbp_ratio))
    lap("tournament")
    winner = verdict.winner
    prob, net, fit, checked = chosen.prob, nets[winner], fitted[winner].fit, fitted[winner].losses
    net.load_state_dict(fitted[winner].state)
    log.info("selection: %s", verdict.reason)
    if optim.refine:
        fit, checked = _refine(prob, session, net, fit, seed, optim, render)
    times, units, held = prob.clock(frame_times), prob.units, prob.held_losses(checked)
    trace = _trace(session, prob, fit, times, render)
    frames, sdf = _frames(fit, times, render, prob.grid)
    heldout_loss = float(held.mean()) if len(held) else float("nan")
    base = references() if math.isfinite(heldout_loss) else None
    return NCTResult(
        frames=(frames * units.intensity).astype(np.float32), sdf=(sdf * units.length).astype(np.float32),
        intensities=(net.intensities.detach().cpu().double() * units.intensity).numpy(),
        heldout_loss=heldout_loss, misfits=None if base is None else replace(base, nct=heldout_loss),
        heldout_se=heldout_standard_error(held), stages=session.stages,
        model={"motion": winner.rung, **asdict(winner.scene), "family": model.family, **net.describe()},
        selection=_selection(verdict, model, rungs), init=_init_record(chosen, winner, init.levels),
        trace=trace, background=_background(net, units), fitted=_fitted(prob, fit, winner, model, sino, grid, render))


def _worse_than_fbp(references: Callable[[], HeldoutMisfits | None], ratio: float) -> Callable[[float], bool]:
    """Whether a fit with a given held-out misfit explains the held-out views worse than ``ratio`` x FBP, beyond the
    noise (select/misfits.py); never where no view is held out (``references``: FBP's and the noise's misfits, the
    data's alone, None then)."""

    def worse(misfit: float) -> bool:
        base = references()
        return base is not None and math.isfinite(misfit) and replace(base, nct=misfit).above_fbp(ratio)

    return worse


def _check(n_objects: int | None, logger: str) -> None:
    """The arguments a caller of ``reconstruct`` may get wrong, named."""
    if n_objects is not None and n_objects < 1:
        raise ValueError(f"n_objects must be >= 1 (or None: chosen from the data), got {n_objects}")
    if logger not in LOGGERS:
        raise ValueError(f"logger must be one of {LOGGERS}, got {logger!r}")


def _selection(verdict: Verdict, model: ModelConf, rungs: Ladder) -> dict:
    """What metrics.json records of the tournament: the winner, why, and every candidate's row (a rung the
    ``rungs`` left out too)."""
    winner, motion = verdict.winner, rungs.motion
    return {"winner": winner.name, "rung": winner.rung, "f_max": winner.f_max or model.f_max,
            "reason": verdict.reason, "table": [asdict(row) for row in verdict.rows + rungs.rows(winner)],
            "tolerance": motion.tolerance, "first_budget": motion.first_budget}


def _background(net: SpaceTimeField, units: Units) -> np.ndarray | None:
    """The fitted static image [H, W] in the data's units, if the model has one."""
    if net.background is None:
        return None
    return (net.background.detach().cpu().numpy() * units.intensity).astype(np.float32)


def _fitted(prob: Problem, fit: FieldStage, winner: Candidate, model: ModelConf, sino: Sinogram, grid: ImageGrid,
            render: RenderConf) -> FittedField:
    """The winner's field (on the CPU, from its last stage ``fit``) and what rebuilds it (its model as built:
    `select.race.Race.start`) and renders it as that stage drew it."""
    net = fit.field.cpu()
    built = model if winner.f_max is None else replace(model, f_max=winner.f_max)
    shape = None if net.background is None else tuple(net.background.shape)
    spec = FieldSpec(built, winner.rung, winner.scene.n_objects, prob.span, shape)
    return FittedField(net, spec, prob.units, grid, prob.clock, acquisition_span(sino.times), render, fit.lattice)


def _refine(prob: Problem, session: Session, net: SpaceTimeField, fit: SinogramFit, seed: int, optim: OptimConf,
            render: RenderConf) -> tuple[SinogramFit, np.ndarray]:
    """The second pass (``optim.refine``): it continues the winner, InitFit re-distancing it to Algorithm 2's SDF
    of its own binarised frames; returns its SinogramFit and the check views' misfits."""
    targets = masks_to_sdf(binarise(field_frames(fit, prob.init_times)), prob.grid.pixel_size,
                           workers=torch.get_num_threads())
    rng, _ = streams(seed, "refine")
    refine_optim, refine_render = replace(optim, lr=optim.refine_lr), replace(render, band_start_px=render.band_px)
    init_fit(prob, session, net, "refine", Start(targets), optim.refine_init_steps, refine_optim, refine_render, rng)
    done = sinogram_fit(prob, session, net, "refine", optim.refine_fit_steps, refine_optim, refine_render, rng)
    return done.fit, done.losses


def _init_record(chosen: SceneSetup, winner: Candidate, levels_from: str) -> dict:
    """metrics.json's ``init``: the winner's start (init/segmentation.py's route, levels) and the units, in the
    data's."""
    seg, units = chosen.found.ranked[winner.start], chosen.prob.units
    return {"route": seg.route, "smoothing_px": seg.smoothing_px, "levels_from": levels_from, "start": winner.start,
            "starts_tried": chosen.n_starts, "levels_misfit": seg.misfit,
            "background": seg.background * units.intensity,
            "levels": [float(a) * units.intensity for a in seg.intensities], "length_unit": units.length,
            "intensity_unit": units.intensity}


def _trace(session: Session, prob: Problem, fit: SinogramFit, times: torch.Tensor,
           render: RenderConf) -> list[TracePoint]:
    """The run's snapshots rendered at ``times`` [F] (frames in data units), ending with the output field
    of ``fit`` where it differs from the last snapshot; ``fit``'s field is left as it was."""
    shots = session.snapshots
    if not shots:
        return []
    out = copy.deepcopy(fit.field.state_dict())
    last = shots[-1]
    if last.stage.field is not fit.field or not _same_state(last.state, out):
        shots.append(snapshot("output", last.step, fit, session.clock))
    trace = []
    for snap in shots:
        snap.stage.field.load_state_dict(snap.state)
        trace.append(TracePoint(snap.name, snap.step, snap.seconds,
                                _frames(snap.stage, times, render, prob.grid)[0] * prob.units.intensity))
    fit.field.load_state_dict(out)
    return trace


def _same_state(a: dict[str, torch.Tensor], b: dict[str, torch.Tensor]) -> bool:
    """Whether two state dicts hold the same keys and values."""
    return a.keys() == b.keys() and all(torch.equal(a[k], b[k]) for k in a)


def _frames(stage: FieldStage, times: torch.Tensor, render: RenderConf, grid: ImageGrid) -> tuple[np.ndarray, np.ndarray]:
    """Algorithm 6 on the stage's field at ``times`` [F]: intensity frames [F, H, W] and SDF frames
    [F, K, H, W], in the method's units."""
    sdf = field_frames(stage, times)
    field = stage.field
    amplitudes = field.intensities.detach().cpu()
    background = None if field.background is None else field.background.detach().cpu()
    return intensity(torch.from_numpy(sdf), amplitudes, render.band_px * grid.pixel_size, render.mu,
                     background).numpy(), sdf
