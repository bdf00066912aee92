"""NeuralCT end to end (Algorithms 1-6 and refinement): a sinogram in, intensity frames out.

Every n-th view (``heldout.every``) is held out of everything, FBP included, and scores
the fit afterwards: a truth-free number for choosing settings. Time is measured in gantry
rotations from the first view, derived from the views' angles and times.
"""

from __future__ import annotations

import copy
import logging
import math
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path

import lightning as L
import numpy as np
import torch

from nct.acquisition.scanner import ImageGrid
from nct.acquisition.sinogram import Sinogram
from nct.method.capacity import (
    CapacityConf,
    Rung,
    band_kept,
    boundary_motion_px,
    climb,
    explain,
    object_models,
)
from nct.method.conf import (
    HeldoutConf,
    InitConf,
    LossConf,
    OptimConf,
    RenderConf,
    TrainerConf,
)
from nct.method.fields import Field, ModelConf, build_field
from nct.method.judge import sinogram_judge
from nct.method.normalise import field_of_view
from nct.method.race import HeldoutHistory, lost, race
from nct.method.render import intensity
from nct.method.sdf import binarise, masks_to_sdf
from nct.method.segment import Segmentation, segmentations
from nct.method.stages import FieldStage, InitFit, SinogramFit, Views
from nct.method.trainer import (
    LOGGERS,
    HeldoutStop,
    IndexDataModule,
    MinLossStop,
    RunClock,
    Snapshot,
    SnapshotLog,
    run_stage,
    snapshot,
)
from nct.physics.data_term import view_noise
from nct.physics.projector import fbp_frames

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

    frames: [F, H, W] float32 intensity sum_k a(k) zeta_k; sdf: [F, K, H, W] float32 (physical
    units, positive inside); intensities: [K] a(k) estimated from the data (Algorithm 1, then
    fitted with the field when optim.fit_intensities); heldout_loss: relative
    sinogram L1 on the held-out views (NaN if none) and heldout_se its standard error
    (``heldout_standard_error``); stages: per stage {steps, losses,
    wall_time_s}; capacity: description of the model; init: how the first SDF frames were
    found (segment.py's route, background and object levels) and the units (normalise.py), in
    the data's units; trace: the field's snapshots (``trainer.snapshot_every_n_steps``) as frames.
    """

    frames: np.ndarray
    sdf: np.ndarray
    intensities: np.ndarray
    heldout_loss: float
    heldout_se: float = float("nan")
    stages: dict = field(default_factory=dict)
    capacity: dict = field(default_factory=dict)
    init: dict = field(default_factory=dict)
    trace: list[TracePoint] = field(default_factory=list)


def rotations_since_start(sino: Sinogram) -> Callable[[np.ndarray], torch.Tensor]:
    """Map seconds to gantry rotations since the first view, from the views' angles and times."""
    span_t = float(np.ptp(sino.times))
    turns_per_s = float(np.ptp(np.unwrap(sino.angles))) / (2 * math.pi) / span_t if span_t > 0 else 0.0
    if not turns_per_s > 0:
        raise ValueError("the sinogram's views must span a positive time and gantry angle")
    t0 = float(sino.times[0])
    return lambda t: torch.as_tensor((np.asarray(t, dtype=np.float64) - t0) * turns_per_s, dtype=torch.float32)


def rotations_spanned(sino: Sinogram) -> float:
    """Gantry rotations from the first view to the last."""
    return float(rotations_since_start(sino)(sino.times).max())


BAND_PREFIX = "band_"  # the stages of the first pass at the wider temporal band


def pass_prefix(n_terms: int, auto: bool, band: bool = False) -> str:
    """The stage names' prefix of a first pass: the wider band's, a ladder rung's (``m<M>_``,
    with ``capacity.auto``) or none; the pass's stages are ``<prefix>init*`` and ``<prefix>fit*``."""
    return BAND_PREFIX if band else f"m{n_terms}_" if auto else ""


def split_views(n_views: int, every: int, run: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """Indices of the fitted and the held-out views: runs of ``run`` consecutive views, every
    ``every``-th run held out (the middle one of each ``every`` runs)."""
    if every < 2:
        return np.arange(n_views), np.zeros(0, dtype=int)
    held = (np.arange(n_views) // run) % every == every // 2
    return np.flatnonzero(~held), np.flatnonzero(held)


def subset(sino: Sinogram, views: np.ndarray) -> Sinogram:
    """The given views of ``sino``, without its truth."""
    return replace(sino, values=sino.values[views], angles=sino.angles[views], times=sino.times[views], truth=None)


@torch.no_grad()
def field_frames(fit: SinogramFit | InitFit, times: torch.Tensor, chunk: int = 32) -> np.ndarray:
    """Algorithm 5: the field sampled on the grid at ``times`` [T] (rotations): [T, K, H, W] f32."""
    return np.concatenate([fit.grid_sdf(part.to(fit.device))[0].cpu().numpy() for part in times.split(chunk)])


@dataclass
class _Problem:
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


def _fit_pass(prob: _Problem, net: Field, prefix: str, steps: tuple[int, int], optim: OptimConf,
              render: RenderConf, starts: list[Start], stages: dict, lattice: int | None = None,
              stop: Callable[[HeldoutHistory], bool] | None = None,
              start_race: Callable[[HeldoutHistory, HeldoutHistory], dict | None] | None = None,
              ) -> tuple[SinogramFit, np.ndarray, int]:
    """One pass: InitFit to each start's SDF targets, then SinogramFit from the start whose field
    misfits the ``_check_views`` least (the leader), the field on a ``lattice``^2 lattice (None: the
    grid's); records the stages in ``stages``. A SinogramFit whose misfit ends above where it started
    is rerun from the InitFit's field at half the rates (``optim.retries``) and the attempt with the
    lowest misfit kept. ``start_race`` (race.py's rule, from the challenger's and the leader's
    held-out histories): each other start's SinogramFit runs too, stops where the rule says it lost,
    and is kept where it ends with a lower misfit than the leader's (None: the leader only).
    ``stop``: a SinogramFit ends after a held-out check where it says so from the held-out history,
    and is not rerun. Returns the fit, its misfit on each check view [c] and the kept start's index."""
    init_steps, fit_steps = steps
    check = torch.from_numpy(_check_views(prob))

    def sinogram_fit(rate: float) -> SinogramFit:
        return SinogramFit(net, prob.grid, replace(optim, lr=optim.lr * rate, intensity_lr=optim.intensity_lr * rate),
                           render, prob.loss, prob.views, fit_steps, lattice)

    def init_name(n: int) -> str:
        return prefix + "init" + (f"_start{n}" if n else "")

    def fit_stage(fit: SinogramFit, name: str, start: int, stream: np.random.Generator,
                  stops: Callable[[HeldoutHistory], bool] | None) -> _Attempt:
        stages[name] = run_stage(
            fit, IndexDataModule(prob.fit_views, optim.batch_views, fit_steps, _stream(stream), prob.held_views),
            fit_steps, name, prob.trainer, prob.log_dir, prob.logger,
            (MinLossStop(optim.min_loss), *_snapshot_log(prob, name), *([HeldoutStop(stops)] if stops else [])),
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
                                      _stream(prob.starts_rng if n else prob.rng)),
                init_steps, name, prob.trainer, prob.log_dir, prob.logger, _snapshot_log(prob, name), resume=prob.resume)
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


def _snapshot_log(prob: _Problem, name: str) -> tuple[SnapshotLog, ...]:
    """The snapshot callback of stage ``name``, if the run keeps a trace."""
    every = prob.trainer.snapshot_every_n_steps
    return (SnapshotLog(name, every, prob.snapshots, prob.clock),) if every else ()


def _same_state(a: dict[str, torch.Tensor], b: dict[str, torch.Tensor]) -> bool:
    """Whether two state dicts hold the same keys and values."""
    return a.keys() == b.keys() and all(torch.equal(a[k], b[k]) for k in a)


def _check_views(prob: _Problem, most: int = 64) -> np.ndarray:
    """The views that judge whether a fit went astray: the held-out ones, or up to ``most`` fitted ones."""
    if len(prob.held_views):
        return prob.held_views
    return prob.fit_views[np.unique(np.linspace(0, len(prob.fit_views) - 1, most).round().astype(int))]


def _held_losses(prob: _Problem, checked: np.ndarray) -> np.ndarray:
    """The held-out views' misfits [h] among a pass's ``checked`` ones (``_check_views``): none
    when no view is held out (the check then ran on fitted views)."""
    return checked if len(prob.held_views) else np.zeros(0)


def _mean_or_nan(losses: np.ndarray) -> float:
    return float(losses.mean()) if len(losses) else float("nan")


def heldout_standard_error(losses: np.ndarray, blocks: int = 10) -> float:
    """Standard error of the mean of per-view held-out ``losses`` [v] (in time order), from the
    means of ``blocks`` contiguous blocks: neighbouring views see nearly the same object and
    angle, so their misfits are not independent. NaN with fewer than 2 views."""
    if len(losses) < 2:
        return float("nan")
    means = [part.mean() for part in np.array_split(losses, min(blocks, len(losses)))]
    return float(np.std(means, ddof=1) / math.sqrt(len(means)))


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
    capacity: CapacityConf | None = None,
    optim: OptimConf | None = None,
    render: RenderConf | None = None,
    init: InitConf | None = None,
    heldout: HeldoutConf | None = None,
    resume: bool = False,
) -> NCTResult:
    """Reconstruct intensity frames at ``frame_times`` [F] (s) on ``grid``; never reads ``sino.truth``.

    The data are fitted in the method's units (normalise.py) and the frames, SDFs and
    intensities returned in the data's. ``trainer``: Lightning's settings; ``optim``, ``render``,
    ``init``, ``heldout``: the config groups of those names (their defaults when None). With
    ``capacity.auto`` the first pass is run for each rung of the ladder (prefix ``m<M>_``) and the
    refinement continues the chosen rung; on scans of several rotations the first pass is also run at
    the wider temporal band ``capacity.band_f_max`` (prefix ``band_``; ``capacity.band_choice``).
    ``resume``: stages that finished before in ``log_dir`` are loaded from their checkpoints, not
    run again (``stages.run_stage``).
    """
    capacity = capacity or CapacityConf()
    optim, render = optim or OptimConf(), render or RenderConf()
    init, heldout = init or InitConf(), heldout or HeldoutConf()
    if n_objects < 1:
        raise ValueError(f"n_objects must be >= 1, got {n_objects}")
    if logger not in LOGGERS:
        raise ValueError(f"logger must be one of {LOGGERS}, got {logger!r}")
    run_clock = RunClock()
    L.seed_everything(seed, verbose=False)
    rng = np.random.default_rng(seed)
    clock = rotations_since_start(sino)
    fit_views, held_views = split_views(sino.n_views, heldout.every, heldout.run)
    if capacity.auto and not len(held_views):
        raise ValueError("capacity.auto needs held-out views: set heldout.every >= 2")
    n_init = max(2, round(init.frames_per_rotation * float(clock(sino.times[-1]))))
    init_times = sino.times[0] + (np.arange(n_init) + 0.5) * (np.ptp(sino.times) / n_init)

    # From here on, the method's units (normalise.py): FOV side 1, intensities about 1.
    lengths = field_of_view(grid)
    grid = lengths.grid(grid)
    fbp = fbp_frames(subset(lengths.sinogram(sino), fit_views), grid, init_times, fbp_window_deg, fbp_filter)
    units = lengths.with_intensity_of(fbp)
    fbp, sino = fbp / units.intensity, units.sinogram(sino)  # lengths' intensity unit is 1
    views = Views(torch.from_numpy(np.asarray(sino.values, dtype=np.float32)),
                  torch.as_tensor(sino.angles, dtype=torch.float32), clock(sino.times), sino.geometry,
                  view_noise(sino, loss.data_term))
    judge = None
    if init.levels == "sinogram":
        fitted = torch.from_numpy(fit_views)
        judge = sinogram_judge(clock(init_times), views.values[fitted], views.angles[fitted], views.times[fitted],
                               views.geometry, grid.extent)
    segs = candidate_starts(segmentations(fbp, n_objects, rng, init.kappa, init.gmm_share, init.route, judge),
                            n_objects, init.starts)
    starts = [Start(masks_to_sdf(s.masks, grid.pixel_size, workers=torch.get_num_threads()), s.intensities)
              for s in segs]
    prob = _Problem(grid, loss, views, clock(init_times), fit_views, held_views, rng, log_dir, logger, trainer,
                    heldout.check_every, resume, run_clock, [], np.random.default_rng([seed, 1]))

    stages: dict = {}
    fitted: dict[int, tuple[Field, SinogramFit, np.ndarray, int]] = {}
    replay = copy.deepcopy(prob.rng), copy.deepcopy(prob.starts_rng), torch.get_rng_state()  # the first pass's streams

    def start_race(challenger: HeldoutHistory, leader: HeldoutHistory) -> dict | None:
        return race(challenger, leader, optim.fit_steps, init.race_at, init.race_gain)

    def first_pass(conf: ModelConf, prefix: str, on: _Problem,
                   stop: Callable[[HeldoutHistory], bool] | None = None) -> tuple[Field, SinogramFit, np.ndarray, int]:
        with torch.random.fork_rng():  # the field's weights from the seed alone, whatever ran before (resume)
            torch.manual_seed(seed)
            net = build_field(conf, n_objects, torch.Generator().manual_seed(seed))
        fit, checked, start = _fit_pass(on, net, prefix, (optim.init_steps, optim.fit_steps), optim, render,
                                        starts, stages, optim.coarse_size, stop,
                                        start_race if init.race_at is not None else None)
        return net, fit, checked, start

    def fit_rung(n_terms: int) -> Rung:
        fitted[n_terms] = net, _, checked, _ = first_pass(replace(model, n_terms=n_terms),
                                                          pass_prefix(n_terms, capacity.auto), prob)
        return Rung(n_terms, _mean_or_nan(_held_losses(prob, checked)), net.describe()["n_params"])

    tried, chosen = climb(capacity.ladder if capacity.auto else [model.n_terms], fit_rung, capacity.tolerance)
    net, fit, checked, start = fitted[chosen.n_terms]
    band = None
    if capacity.tries_band(model.f_max, rotations_spanned(sino), chosen.n_terms, len(held_views) > 0):
        # Run as a first pass at the wider band would (same streams), so a kept band is that run;
        # it races the configured fit's held-out history and stops where it falls behind.
        def band_race(history: HeldoutHistory) -> dict | None:
            return capacity.band_race(history, fit.heldout_history, optim.fit_steps)

        def behind(history: HeldoutHistory) -> bool:
            return lost(band_race(history))

        with torch.random.fork_rng():
            torch.set_rng_state(replay[2])
            wide = first_pass(replace(model, n_terms=chosen.n_terms, f_max=capacity.band_f_max), BAND_PREFIX,
                              replace(prob, rng=replay[0], starts_rng=replay[1]), behind)
        band = capacity.band_choice(model.f_max, chosen.heldout_loss, _mean_or_nan(_held_losses(prob, wide[2])),
                                    band_race(wide[1].heldout_history))
        log.info("temporal band: %s: keeping F_max %g", band["reason"], band["kept_f_max"])
        if band_kept(band):
            (net, fit, checked, start), model = wide, replace(model, f_max=capacity.band_f_max)
    seg = segs[start]

    masks = binarise(field_frames(fit, prob.init_times))
    objects = object_models(boundary_motion_px(masks), capacity.static_below_px if chosen.n_terms else math.inf)
    static = np.array([o["model"] == "static" for o in objects])
    if chosen.n_terms and static.any():
        net.set_static(torch.from_numpy(static), float(prob.init_times.mean()))
        masks[:, static] = masks[:, static].mean(axis=0) > 0.5
        checked = fit.view_losses(torch.from_numpy(_check_views(prob)))  # the held-out score of what is output

    if optim.refine:
        # The second pass continues the chosen field (from random weights it would need as many
        # steps as the first): InitFit re-distances it to Algorithm 2's SDF of its own binarised frames.
        targets = masks_to_sdf(masks, grid.pixel_size, workers=torch.get_num_threads())
        fit, checked, _ = _fit_pass(prob, net, "refine_", (optim.refine_init_steps, optim.refine_fit_steps),
                                    replace(optim, lr=optim.refine_lr), replace(render, band_start_px=render.band_px),
                                    [Start(targets)], stages)

    trace = _trace(prob, fit, clock(frame_times), render, grid, units.intensity)
    frames, sdf = _frames(fit, clock(frame_times), render, grid)
    amplitudes = net.intensities.detach().cpu()
    frames, sdf, amplitudes = frames * units.intensity, sdf * units.length, amplitudes.double() * units.intensity
    described = {"model": model.name, "family": model.family, "f_max": model.f_max, **net.describe()}
    described["objects"] = {"static_below_px": capacity.static_below_px, "per_object": objects}
    if band:
        described["band"] = band
    if capacity.auto:
        described["choice"] = {
            "ladder": [vars(r) for r in tried], "tolerance": capacity.tolerance,
            "reason": explain(tried, chosen, capacity.tolerance),
        }
    held = _held_losses(prob, checked)
    return NCTResult(frames=frames.astype(np.float32), sdf=sdf.astype(np.float32), intensities=amplitudes.numpy(),
                     heldout_loss=_mean_or_nan(held),
                     heldout_se=heldout_standard_error(held), stages=stages, capacity=described,
                     init={"route": seg.route, "smoothing_px": seg.smoothing_px, "levels_from": init.levels,
                           "start": start, "starts_tried": len(segs),
                           "levels_misfit": seg.misfit, "background": seg.background * units.intensity,
                           "levels": [float(a) * units.intensity for a in seg.intensities],
                           "length_unit": units.length, "intensity_unit": units.intensity},
                     trace=trace)


def _trace(prob: _Problem, fit: SinogramFit, times: torch.Tensor, render: RenderConf, grid: ImageGrid,
           intensity_unit: float) -> list[TracePoint]:
    """The run's snapshots rendered at ``times`` [F] (frames in data units), ending with the field of
    ``fit`` that is output where it differs from the last snapshot (objects made static, an earlier
    attempt kept); ``fit``'s field is left as it was."""
    if not prob.snapshots:
        return []
    out = fit.field.state_dict()
    if not _same_state(prob.snapshots[-1].state, out):
        prob.snapshots.append(snapshot("output", prob.snapshots[-1].step, fit, prob.clock))
    output = prob.snapshots[-1].state
    trace = []
    for snap in prob.snapshots:
        snap.stage.field.load_state_dict(snap.state)
        trace.append(TracePoint(snap.name, snap.step, snap.seconds,
                                _frames(snap.stage, times, render, grid)[0] * intensity_unit))
    fit.field.load_state_dict(output)
    return trace


def _frames(stage: FieldStage, times: torch.Tensor, render: RenderConf, grid: ImageGrid) -> tuple[np.ndarray, np.ndarray]:
    """Algorithm 6 on the stage's field at ``times`` [F]: intensity frames [F, H, W] and SDF frames
    [F, K, H, W], in the method's units."""
    sdf = field_frames(stage, times)
    amplitudes = stage.field.intensities.detach().cpu()
    return intensity(torch.from_numpy(sdf), amplitudes, render.band_px * grid.pixel_size, render.mu).numpy(), sdf


def _stream(rng: np.random.Generator) -> int:
    """A seed for a stage's own sampler, drawn from the run's generator."""
    return int(rng.integers(2**31 - 1))
