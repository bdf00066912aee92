"""NeuralCT end to end: a sinogram in, intensity frames out, never reading the truth.

The way through runs downwards: prepare (units, views, FBP: prepare.py) -> initialise (starts:
initialise.py) -> fit and select (each candidate, a motion rung from a start, fitted and scored on the
held-out views in one tournament: fitting.py, select.py) -> refine the winner -> frames.
"""

from __future__ import annotations

import copy
import logging
from dataclasses import asdict, dataclass, field, replace
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
from nct.method.select import Candidate, SceneModel, SelectionConf, Tournament, Verdict
from nct.method.stages import FieldStage, SinogramFit
from nct.method.trainer import LOGGERS, RunClock, snapshot

log = logging.getLogger(__name__)
RESTART_RATE = 0.5  # a fit whose misfit ends above its start is tried again at this share of its rates
EMPTY = 0.999  # a misfit above this share of an empty image's explains nothing: a field faded to nothing renders
# its sigmoid tails and scores a hair below the empty image (the tiny test's small disc: 1 - 2e-8)


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


def candidates(motion: SelectionConf, starts: list[Start], span: float, scene: SceneModel, turning: int = 0,
               scene_named: bool = False) -> list[Candidate]:
    """The candidates of one ``scene`` model: each rung of ``motion.rungs`` from each start, and on a scan of
    ``span`` >= ``motion.band_min_rotations`` rotations the free rung at ``motion.band_f_max`` too; simpler
    models, then better judged starts, first. Where one of ``turning`` objects turns with a part's axis read
    off the views (prepare.py), the free rung from the best judged start turning each of them in turn: the
    same model, which object turns the held-out views tell."""
    bands: list[tuple[str, float | None]] = [(rung, None) for rung in motion.rungs]
    if "free" in motion.rungs and motion.band_f_max is not None and span >= motion.band_min_rotations:
        bands.append(("free", motion.band_f_max))
    pool = [Candidate(scene, rung, n, f_max, scene_named=scene_named)
            for rung, f_max in bands for n in range(len(starts))]
    if "free" not in motion.rungs:
        return pool
    return pool + [Candidate(scene, "free", turning=k, scene_named=scene_named) for k in range(turning)]


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
) -> NCTResult:
    """Reconstruct intensity frames at ``frame_times`` [F] (s) on ``grid``; never reads ``sino.truth``.

    The data are fitted in the method's units (normalise.py) and the frames, SDFs and intensities
    returned in the data's. Every candidate (``motion.rungs`` x the starts) is fitted and scored on the
    held-out views in one tournament (select.py); the winner is refined (``optim.refine``).
    ``background=image``: a static image under the objects, fitted with them (background.py).
    ``resume``: stages that finished before in ``log_dir`` are loaded from their checkpoints.
    """
    motion, optim, render = motion or SelectionConf(), optim or OptimConf(), render or RenderConf()
    init, heldout, background = init or InitConf(), heldout or HeldoutConf(), background or BackgroundConf()
    if n_objects < 1:
        raise ValueError(f"n_objects must be >= 1, got {n_objects}")
    if logger not in LOGGERS:
        raise ValueError(f"logger must be one of {LOGGERS}, got {logger!r}")
    session = Session(trainer, log_dir, logger, heldout.check_every, resume, RunClock(), [], {})
    L.seed_everything(seed, verbose=False)
    setups = [set_up(sino, grid, SceneModel(n_objects, background.name), seed, loss, init, heldout, background,
                     (fbp_filter, fbp_window_deg))]
    verdict, fitted, nets = _tournament(setups, session, model, seed, motion, optim, render)
    winner = verdict.winner
    chosen = next(s for s in setups if s.model == winner.scene)
    prob = chosen.prob
    net, fit, checked = nets[winner], fitted[winner].fit, fitted[winner].losses
    net.load_state_dict(fitted[winner].state)
    log.info("selection: %s", verdict.reason)
    if optim.refine:
        fit, checked = _refine(prob, session, net, fit, seed, optim, render)
    times = prob.clock(frame_times)
    trace = _trace(session, prob, fit, times, render)
    frames, sdf = _frames(fit, times, render, prob.grid)
    units = prob.units
    held = prob.held_losses(checked)
    return NCTResult(
        frames=(frames * units.intensity).astype(np.float32), sdf=(sdf * units.length).astype(np.float32),
        intensities=(net.intensities.detach().cpu().double() * units.intensity).numpy(),
        heldout_loss=float(held.mean()) if len(held) else float("nan"),
        heldout_se=heldout_standard_error(held), stages=session.stages,
        model={"motion": winner.rung, "family": model.family, **net.describe()},
        selection={"winner": winner.name, "rung": winner.rung, "f_max": winner.f_max or model.f_max,
                   "reason": verdict.reason, "table": [asdict(row) for row in verdict.rows],
                   "tolerance": motion.tolerance, "first_budget": motion.first_budget},
        init=_init_record(chosen, winner, init.levels),
        trace=trace,
        background=None if net.background is None else
        (net.background.detach().cpu().numpy() * units.intensity).astype(np.float32))


@dataclass
class SceneSetup:
    """One scene model's share of a run: its ``Problem`` (prepare.py), its judged ``starts`` and the run's
    random generator as a run of that model alone holds it once they are found (the paper's field continues it)."""

    model: SceneModel
    prob: Problem
    starts: list[Start]
    rng: np.random.Generator


def set_up(sino: Sinogram, grid: ImageGrid, scene: SceneModel, seed: int, loss: LossConf, init: InitConf,
           heldout: HeldoutConf, background: BackgroundConf, fbp: tuple[str, float]) -> SceneSetup:
    """Prepare the data (prepare.py) and find the starts (initialise.py) of one ``scene`` model; ``fbp``: the
    FBP frames' filter and window (degrees). A lone object without a background is held along its path, several
    without one are searched for a turning part; over a background the objects are sought in what moves."""
    image = scene.background == "image"
    prob = prepare(sino, grid, loss, init, heldout, *fbp, lone=scene.n_objects == 1 and not image,
                   parts=scene.n_objects > 1 and not image)
    rng = np.random.default_rng(seed)
    starts = find_starts(prob, scene.n_objects, init, rng, replace(background, name=scene.background))
    return SceneSetup(scene, prob, starts, rng)


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
    """metrics.json's ``init``: the winner's start (segment.py's route, levels), the units, in the data's, and the
    degrees of view angle a held axis leaves its object's own frame seen over (prepare.py; None: none held)."""
    seg, prob, units = chosen.starts[winner.start].segmentation, chosen.prob, chosen.prob.units
    return {"route": seg.route, "smoothing_px": seg.smoothing_px, "levels_from": levels_from, "start": winner.start,
            "starts_tried": len(chosen.starts), "levels_misfit": seg.misfit,
            "frame_coverage_deg": prob.frame_coverage_deg, "background": seg.background * units.intensity,
            "levels": [float(a) * units.intensity for a in seg.intensities], "length_unit": units.length,
            "intensity_unit": units.intensity}


def _tournament(setups: list[SceneSetup], session: Session, model: ModelConf, seed: int, motion: SelectionConf,
                optim: OptimConf, render: RenderConf,
                ) -> tuple[Verdict, dict[Candidate, Fitted], dict[Candidate, SpaceTimeField]]:
    """Fit every candidate of every scene model and choose one (select.py). All InitFits run first; the sinogram
    fits then run from the best-started candidate on, so that the later ones race the best histories. A fit that
    ends above where it started, or explains the check views no better than an empty image, has lost its way
    (an object fell out of the band, where no gradient reaches it): a restart joins the tournament at
    ``RESTART_RATE`` of the rates, from the candidate's InitFit, or from a fresh draw of the field (its own
    weights and InitFit) where that InitFit explained nothing either. A fit that diverges drops out (its
    restart joins likewise); the run fails with its error only when no candidate finishes. Each candidate
    draws from its own streams (fitting.streams); the paper's field continues its scene model's generator."""
    by_model = {s.model: s for s in setups}
    nets: dict[Candidate, SpaceTimeField] = {}
    started: dict[Candidate, tuple[float, dict, np.random.Generator]] = {}

    def start(cand: Candidate) -> None:
        setup = by_model[cand.scene]
        rng, torch_seed = (setup.rng, seed) if cand.continues_run else streams(seed, cand.key)
        with torch.random.fork_rng():  # the field's weights and its InitFit from the candidate's own streams
            torch.manual_seed(torch_seed)
            conf = model if cand.f_max is None else replace(model, f_max=cand.f_max)
            nets[cand] = net = build_field(conf, cand.scene.n_objects, torch.Generator().manual_seed(torch_seed),
                                           cand.rung, setup.prob.span)
            begin = setup.starts[cand.start]
            begin = begin if cand.turning is None else turned_start(setup.prob, begin, cand.turning)
            misfit = init_fit(setup.prob, session, net, cand.name, begin, optim.init_steps, optim, render, rng,
                              optim.coarse_size)
        started[cand] = misfit, copy.deepcopy(net.state_dict()), rng

    named = len(setups) > 1
    pool = [c for s in setups for c in candidates(
        motion, s.starts, s.prob.span, s.model, 0 if s.prob.part_orientations is None else s.model.n_objects, named)]
    for cand in pool:
        start(cand)
    tournament = Tournament(optim.fit_steps, session.check_every if len(setups[0].prob.held_views) else 0, motion)
    empty = EMPTY * setups[0].prob.empty_misfit()
    fitted: dict[Candidate, Fitted] = {}
    diverged: DivergenceError | None = None  # the first: the run's error when no candidate finishes
    queue = sorted(pool, key=lambda c: started[c][0])
    while queue:
        cand = queue.pop(0)
        base = replace(cand, restart=False)
        if cand.restart and started[base][0] >= empty:
            start(cand)
        elif cand.restart:
            nets[cand], started[cand] = nets[base], started[base]
        lost, done = _fit(cand, by_model[cand.scene].prob, session, nets[cand], started[cand], seed, tournament,
                          (optim, render), empty)
        if isinstance(done, DivergenceError):
            diverged = diverged or done
        else:
            fitted[cand] = done
        if lost and not cand.restart:
            log.warning("%s; a restart at %g of the rates joins the tournament", lost, RESTART_RATE)
            queue.insert(0, replace(cand, restart=True))
    if diverged is not None and all(e.pruned for e in tournament.entries):
        raise diverged
    return tournament.verdict(), fitted, nets


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
