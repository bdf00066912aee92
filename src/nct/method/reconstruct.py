"""NeuralCT end to end: a sinogram in, intensity frames out, never reading the truth.

The way through runs downwards: prepare (units, views, FBP: prepare.py) -> initialise (starts:
initialise.py) -> fit and select (each candidate, a motion rung from a start, fitted and scored on the
held-out views in one tournament: fitting.py, select.py) -> refine the winner -> frames.
"""

from __future__ import annotations

import copy
import logging
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path

import lightning as L
import numpy as np
import torch

from nct.acquisition.scanner import ImageGrid
from nct.acquisition.sinogram import Sinogram
from nct.errors import DivergenceError
from nct.method.conf import (
    BackgroundConf,
    HeldoutConf,
    InitConf,
    LossConf,
    OptimConf,
    RenderConf,
    TrainerConf,
)
from nct.method.fields import ModelConf, SpaceTimeField, build_field
from nct.method.fitting import Fitted, Session, at_rate, init_fit, sinogram_fit, streams
from nct.method.initialise import Start, find_starts, turned_start
from nct.method.prepare import Problem, heldout_standard_error, prepare
from nct.method.render import intensity
from nct.method.sdf import binarise, masks_to_sdf
from nct.method.select import RUNGS, Candidate, SelectionConf, Tournament, Verdict
from nct.method.stages import FieldStage, SinogramFit
from nct.method.trainer import LOGGERS, RunClock, snapshot

log = logging.getLogger(__name__)
RESTART_RATE = 0.5  # a fit whose misfit ends above its start is tried again at this share of its rates
EMPTY = 0.999  # a misfit above this share of an empty image's explains nothing: a field faded to nothing renders
# its sigmoid tails and scores a hair below the empty image (the tiny test's small disc: 1 - 2e-8)
PAPER = "free"  # the paper's field from the best judged start: the candidate that continues the run's random streams


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
    init: the starts (segment.py's route, levels), the units, in the data's, and the degrees of view angle a
    held axis leaves its object's own frame seen over (prepare.py; None: none held); trace: snapshots;
    background: the static image [H, W] float32 under the objects (``background=image``; None: none).
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


def candidates(motion: SelectionConf, starts: list[Start], span: float, turning: int = 0) -> list[Candidate]:
    """One candidate per model and start (named ``<model>`` for the best judged start, ``<model>_start<n>``
    for the others, so that more starts change no name): each rung of ``motion.rungs``, and on a scan of
    ``span`` >= ``motion.band_min_rotations`` rotations the free rung at ``motion.band_f_max`` too
    (``free_band``); simpler models, then better judged starts, first. Where one of ``turning`` objects
    turns with a part's axis read off the views (prepare.py), the free rung from the best judged start
    turning each of them in turn (``free_turn<k>``): the same model, which object turns the held-out
    views tell."""
    models = [(rung, rung, (RUNGS.index(rung), 0), None) for rung in motion.rungs]
    if "free" in motion.rungs and motion.band_f_max is not None and span >= motion.band_min_rotations:
        models.append(("free_band", "free", (RUNGS.index("free"), 1), motion.band_f_max))
    pool = [Candidate(f"{name}_start{n}" if n else name, rung, simplicity, n, f_max)
            for name, rung, simplicity, f_max in models for n in range(len(starts))]
    if "free" not in motion.rungs:
        return pool
    return pool + [Candidate(f"free_turn{k}", "free", (RUNGS.index("free"), 0), 0, None, k) for k in range(turning)]


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
    n_objects: int = 1,
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

    The data are fitted in the method's units (normalise.py) and the frames, SDFs and intensities
    returned in the data's. Every candidate (``motion.rungs`` x the starts) is fitted and scored on the
    held-out views in one tournament (select.py); the winner is refined (``optim.refine``).
    ``background=image``: a static image under the objects, fitted with them (background.py).
    ``resume``: stages that finished before in ``log_dir`` are loaded from their checkpoints.
    ``lap``: the caller's stopwatch, told as ``initialisation`` and ``tournament`` end.
    """
    motion, optim, render = motion or SelectionConf(), optim or OptimConf(), render or RenderConf()
    init, heldout, background = init or InitConf(), heldout or HeldoutConf(), background or BackgroundConf()
    if n_objects < 1:
        raise ValueError(f"n_objects must be >= 1, got {n_objects}")
    if logger not in LOGGERS:
        raise ValueError(f"logger must be one of {LOGGERS}, got {logger!r}")
    session = Session(trainer, log_dir, logger, heldout.check_every, resume, RunClock(), [], {})
    L.seed_everything(seed, verbose=False)
    prob = prepare(sino, grid, loss, init, heldout, fbp_filter, fbp_window_deg,
                   lone=n_objects == 1 and background.name != "image",
                   parts=n_objects > 1 and background.name != "image")
    run_rng = np.random.default_rng(seed)
    starts = find_starts(prob, n_objects, init, run_rng, background)
    lap("initialisation")
    verdict, fitted, nets = _tournament(prob, session, model, starts, n_objects, (seed, run_rng), motion, optim,
                                        render)
    lap("tournament")
    winner = verdict.winner
    net, fit, checked = nets[winner.name], fitted[winner.name].fit, fitted[winner.name].losses
    net.load_state_dict(fitted[winner.name].state)
    log.info("selection: %s", verdict.reason)

    if optim.refine:
        # The second pass continues the winner: InitFit re-distances it to Algorithm 2's SDF of its own binarised frames.
        targets = masks_to_sdf(binarise(field_frames(fit, prob.init_times)), prob.grid.pixel_size,
                               workers=torch.get_num_threads())
        rng, _ = streams(seed, "refine")
        refine_optim, refine_render = replace(optim, lr=optim.refine_lr), replace(render, band_start_px=render.band_px)
        init_fit(prob, session, net, "refine", Start(targets), optim.refine_init_steps, refine_optim, refine_render, rng)
        done = sinogram_fit(prob, session, net, "refine", optim.refine_fit_steps, refine_optim, refine_render, rng)
        fit, checked = done.fit, done.losses

    times = prob.clock(frame_times)
    trace = _trace(session, prob, fit, times, render)
    frames, sdf = _frames(fit, times, render, prob.grid)
    units = prob.units
    amplitudes = net.intensities.detach().cpu().double() * units.intensity
    seg = starts[winner.start].segmentation
    held = prob.held_losses(checked)
    return NCTResult(
        frames=(frames * units.intensity).astype(np.float32), sdf=(sdf * units.length).astype(np.float32),
        intensities=amplitudes.numpy(), heldout_loss=float(held.mean()) if len(held) else float("nan"),
        heldout_se=heldout_standard_error(held), stages=session.stages,
        model={"motion": winner.rung, "family": model.family, **net.describe()},
        selection={"winner": winner.name, "rung": winner.rung, "f_max": winner.f_max or model.f_max,
                   "reason": verdict.reason, "table": verdict.rows,
                   "tolerance": motion.tolerance, "first_budget": motion.first_budget},
        init={"route": seg.route, "smoothing_px": seg.smoothing_px, "levels_from": init.levels, "start": winner.start,
              "starts_tried": len(starts), "levels_misfit": seg.misfit, "frame_coverage_deg": prob.frame_coverage_deg,
              "background": seg.background * units.intensity,
              "levels": [float(a) * units.intensity for a in seg.intensities], "length_unit": units.length,
              "intensity_unit": units.intensity},
        trace=trace,
        background=None if net.background is None else
        (net.background.detach().cpu().numpy() * units.intensity).astype(np.float32))


def _tournament(prob: Problem, session: Session, model: ModelConf, starts: list[Start], n_objects: int,
                seeds: tuple[int, np.random.Generator], motion: SelectionConf, optim: OptimConf, render: RenderConf,
                ) -> tuple[Verdict, dict[str, Fitted], dict[str, SpaceTimeField]]:
    """Fit every candidate and choose one (select.py). All InitFits run first; the sinogram fits then run
    from the best-started candidate on, so that the later ones race the best histories. A fit that ends
    above where it started, or explains the check views no better than an empty image, has lost its way
    (an object fell out of the band, where no gradient reaches it): a restart joins the tournament at
    ``RESTART_RATE`` of the rates, from the candidate's InitFit, or from a fresh draw of the field (its own
    weights and InitFit) where that InitFit explained nothing either. A fit that diverges drops out (its
    restart joins likewise); the run fails with its error only when no candidate finishes.
    ``seeds``: the run's seed and its generator, which the candidate ``PAPER`` continues (fitting.streams)."""
    seed, run_rng = seeds
    nets: dict[str, SpaceTimeField] = {}
    started: dict[str, tuple[float, dict, np.random.Generator]] = {}

    def start(cand: Candidate) -> None:
        rng, torch_seed = (run_rng, seed) if cand.name == PAPER else streams(seed, cand.name)
        with torch.random.fork_rng():  # the field's weights and its InitFit from the candidate's own streams
            torch.manual_seed(torch_seed)
            conf = model if cand.f_max is None else replace(model, f_max=cand.f_max)
            nets[cand.name] = net = build_field(conf, n_objects, torch.Generator().manual_seed(torch_seed), cand.rung,
                                                  prob.span)
            begin = starts[cand.start] if cand.turning is None else turned_start(prob, starts[cand.start], cand.turning)
            misfit = init_fit(prob, session, net, cand.name, begin, optim.init_steps, optim, render, rng,
                              optim.coarse_size)
        started[cand.name] = misfit, copy.deepcopy(net.state_dict()), rng

    pool = candidates(motion, starts, prob.span, 0 if prob.part_orientations is None else n_objects)
    for cand in pool:
        start(cand)
    tournament = Tournament(optim.fit_steps, session.check_every if len(prob.held_views) else 0, motion)
    empty = EMPTY * prob.empty_misfit()
    fitted: dict[str, Fitted] = {}
    diverged: DivergenceError | None = None  # the first: the run's error when no candidate finishes
    queue = sorted(pool, key=lambda c: started[c.name][0])
    while queue:
        cand = queue.pop(0)
        restart = cand.name.endswith("_restart")
        base = cand.name.removesuffix("_restart")
        if restart and started[base][0] >= empty:
            start(cand)
        elif restart:
            nets[cand.name], started[cand.name] = nets[base], started[base]
        net = nets[cand.name]
        misfit0, state, rng = started[cand.name]
        net.load_state_dict(state)
        try:
            with torch.random.fork_rng():
                torch.manual_seed(seed if cand.name == PAPER else streams(seed, cand.name)[1])
                done = sinogram_fit(prob, session, net, cand.name, optim.fit_steps,
                                    at_rate(optim, RESTART_RATE if restart else 1.0), render, rng, optim.coarse_size,
                                    tournament.stops(cand))
        except DivergenceError as err:  # seen on a GPU: a band candidate at step 100, the free field finished
            diverged = diverged or err
            session.stages[f"{cand.name}_fit"] = {"verdict": f"diverged: {err}"}
            tournament.record(cand, [], 0, float("inf"), failed=f"diverged: {err}")
            lost = f"{err}; it drops out of the tournament"
            if restart:
                log.warning("%s", lost)
        else:
            entry = tournament.record(cand, done.history, done.steps, done.misfit)
            session.stages[f"{cand.name}_fit"]["verdict"] = entry.pruned or "finished"
            fitted[cand.name] = done
            lost = (f"stage {cand.name}_fit: its misfit went from {misfit0:.3g} to {done.misfit:.3g} (an empty "
                    f"image's: {empty:.3g})" if entry.pruned is None and (done.misfit > misfit0 or done.misfit >= empty)
                    else None)
        if lost and not restart:
            log.warning("%s; a restart at %g of the rates joins the tournament", lost, RESTART_RATE)
            queue.insert(0, replace(cand, name=f"{cand.name}_restart"))
    if diverged is not None and all(e.pruned for e in tournament.entries):
        raise diverged
    return tournament.verdict(), fitted, nets


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
