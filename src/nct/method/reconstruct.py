"""NeuralCT end to end (Algorithms 1-6 and refinement): a sinogram in, intensity frames out.

The views' clock and split: prepare.py; one pass (InitFit, SinogramFit, the start race and the
retry): passes.py; here the units, FBP, the starts, the capacity ladder and the temporal band
over the passes, the refinement and the frames.
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
from nct.method.passes import (
    Problem,
    Start,
    candidate_starts,
    check_views,
    fit_pass,
    held_losses,
)
from nct.method.prepare import (
    heldout_standard_error,
    rotations_since_start,
    rotations_spanned,
    split_views,
    subset,
)
from nct.method.race import HeldoutHistory, lost, race
from nct.method.render import intensity
from nct.method.sdf import binarise, masks_to_sdf
from nct.method.segment import segmentations
from nct.method.stages import FieldStage, InitFit, SinogramFit, Views
from nct.method.trainer import (
    LOGGERS,
    RunClock,
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


BAND_PREFIX = "band_"  # the stages of the first pass at the wider temporal band


def pass_prefix(n_terms: int, auto: bool, band: bool = False) -> str:
    """The stage names' prefix of a first pass: the wider band's, a ladder rung's (``m<M>_``,
    with ``capacity.auto``) or none; the pass's stages are ``<prefix>init*`` and ``<prefix>fit*``."""
    return BAND_PREFIX if band else f"m{n_terms}_" if auto else ""


@torch.no_grad()
def field_frames(fit: SinogramFit | InitFit, times: torch.Tensor, chunk: int = 32) -> np.ndarray:
    """Algorithm 5: the field sampled on the grid at ``times`` [T] (rotations): [T, K, H, W] f32."""
    return np.concatenate([fit.grid_sdf(part.to(fit.device))[0].cpu().numpy() for part in times.split(chunk)])


def _same_state(a: dict[str, torch.Tensor], b: dict[str, torch.Tensor]) -> bool:
    """Whether two state dicts hold the same keys and values."""
    return a.keys() == b.keys() and all(torch.equal(a[k], b[k]) for k in a)


def _mean_or_nan(losses: np.ndarray) -> float:
    return float(losses.mean()) if len(losses) else float("nan")


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
    run again (``trainer.run_stage``).
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
    prob = Problem(grid, loss, views, clock(init_times), fit_views, held_views, rng, log_dir, logger, trainer,
                    heldout.check_every, resume, run_clock, [], np.random.default_rng([seed, 1]))

    stages: dict = {}
    fitted: dict[int, tuple[Field, SinogramFit, np.ndarray, int]] = {}
    replay = copy.deepcopy(prob.rng), copy.deepcopy(prob.starts_rng), torch.get_rng_state()  # the first pass's streams

    def start_race(challenger: HeldoutHistory, leader: HeldoutHistory) -> dict | None:
        return race(challenger, leader, optim.fit_steps, init.race_at, init.race_gain)

    def first_pass(conf: ModelConf, prefix: str, on: Problem,
                   stop: Callable[[HeldoutHistory], bool] | None = None) -> tuple[Field, SinogramFit, np.ndarray, int]:
        with torch.random.fork_rng():  # the field's weights from the seed alone, whatever ran before (resume)
            torch.manual_seed(seed)
            net = build_field(conf, n_objects, torch.Generator().manual_seed(seed))
        fit, checked, start = fit_pass(on, net, prefix, (optim.init_steps, optim.fit_steps), optim, render,
                                        starts, stages, optim.coarse_size, stop,
                                        start_race if init.race_at is not None else None)
        return net, fit, checked, start

    def fit_rung(n_terms: int) -> Rung:
        fitted[n_terms] = net, _, checked, _ = first_pass(replace(model, n_terms=n_terms),
                                                          pass_prefix(n_terms, capacity.auto), prob)
        return Rung(n_terms, _mean_or_nan(held_losses(prob, checked)), net.describe()["n_params"])

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
        band = capacity.band_choice(model.f_max, chosen.heldout_loss, _mean_or_nan(held_losses(prob, wide[2])),
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
        checked = fit.view_losses(torch.from_numpy(check_views(prob)))  # the held-out score of what is output

    if optim.refine:
        # The second pass continues the chosen field (from random weights it would need as many
        # steps as the first): InitFit re-distances it to Algorithm 2's SDF of its own binarised frames.
        targets = masks_to_sdf(masks, grid.pixel_size, workers=torch.get_num_threads())
        fit, checked, _ = fit_pass(prob, net, "refine_", (optim.refine_init_steps, optim.refine_fit_steps),
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
    held = held_losses(prob, checked)
    return NCTResult(frames=frames.astype(np.float32), sdf=sdf.astype(np.float32), intensities=amplitudes.numpy(),
                     heldout_loss=_mean_or_nan(held),
                     heldout_se=heldout_standard_error(held), stages=stages, capacity=described,
                     init={"route": seg.route, "smoothing_px": seg.smoothing_px, "levels_from": init.levels,
                           "start": start, "starts_tried": len(segs),
                           "levels_misfit": seg.misfit, "background": seg.background * units.intensity,
                           "levels": [float(a) * units.intensity for a in seg.intensities],
                           "length_unit": units.length, "intensity_unit": units.intensity},
                     trace=trace)


def _trace(prob: Problem, fit: SinogramFit, times: torch.Tensor, render: RenderConf, grid: ImageGrid,
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
