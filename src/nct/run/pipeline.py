"""One run, end to end: data -> FBP -> NeuralCT -> metrics -> files and TensorBoard.

`nct.run.job.run_job` validates the config, records the run's status and calls `run`.
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, replace
from pathlib import Path

import numpy as np
from omegaconf import DictConfig

from nct.acquisition.io import load_sinogram, save_sinogram
from nct.acquisition.scanner import ImageGrid
from nct.acquisition.sinogram import Sinogram
from nct.acquisition.times import slow_rotation_warning
from nct.moments.determinacy import (
    determinacy_warnings,
    motion_determinacy,
    turn_warnings,
)
from nct.physics.projector import fbp_frames
from nct.run import export
from nct.run.config import FileConf, NCTConf, RunSize, check_memory, chosen_objects
from nct.run.consistency import check_geometry, geometry_warnings
from nct.run.folder import read_status
from nct.run.metrics import FrameMetrics, frame_metrics, summarise
from nct.run.phases import Instant, Phases
from nct.run.tables import write_csv
from nct.run.tracking import (
    run_hparams,
    write_frames,
    write_hparams,
    write_motion,
    write_phases,
    write_selection,
    write_trace,
)
from nct.scenes.phantoms import build_phantom
from nct.scenes.simulate import simulate

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class Acquisition:
    """What the reconstruction works from: the data, the output grid and the output frame times [F]."""

    sino: Sinogram
    grid: ImageGrid
    frame_times: np.ndarray
    n_objects: int | None


def acquire(conf: NCTConf, rng: np.random.Generator) -> Acquisition:
    """Simulate the configured scene or load the sinogram file (frames on its truth grid if it has
    one, else ``image.size`` pixels over ``data.extent``); a file's sizes are checked against the
    memory here (a simulation's in `validate`)."""
    if isinstance(conf.data, FileConf):
        log.info("reading %s ...", conf.data.path)
        sino = load_sinogram(conf.data.path, conf.data.sidecar, conf.data.times_unit)
        sino = sino if conf.data.i0 is None else replace(sino, i0=conf.data.i0)
        if sino.truth is not None:
            grid, frame_times = ImageGrid(sino.truth.frames.shape[-1], sino.truth.extent), sino.truth.times
            image_key = f"data.path={conf.data.path} (its truth frames)"
        else:
            extent = conf.data.extent if conf.data.extent is not None else 2 * sino.geometry.field_radius
            grid, image_key = ImageGrid(conf.image.size, extent), f"image.size={conf.image.size}"
            span = float(np.ptp(sino.angles)) / (2 * math.pi)
            n = max(1, round(conf.image.frames_per_rotation * max(span, 1e-9)))
            edges = np.linspace(sino.times[0], sino.times[-1], n + 1)
            frame_times = 0.5 * (edges[:-1] + edges[1:])
        check_memory(conf, RunSize(grid.size, len(frame_times), *sino.values.shape), image_key,
                     f"data.path={conf.data.path}")
        return Acquisition(sino, grid, frame_times, chosen_objects(conf.data.n_objects))
    scanner = conf.scanner.build(conf.image.extent)
    grid = conf.image.build()
    phantom = build_phantom(conf.phantom, scanner.rotation_time)
    frame_times = scanner.frame_times(conf.image.frames_per_rotation)
    log.info("simulating the %s phantom: %d views of %d bins ...", conf.phantom.name, scanner.n_views,
             conf.scanner.n_bins)
    sino = simulate(phantom, scanner, grid, frame_times, conf.data.noise_i0, rng)
    return Acquisition(sino, grid, frame_times, chosen_objects(conf.data.n_objects))


def reconstruct_all(conf: NCTConf, acq: Acquisition, out_dir: Path, lap: Callable[[str], None] = lambda phase: None
                    ) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray], dict, list]:
    """FBP frames, and NeuralCT frames unless ``method=fbp``; returns frames by name, NeuralCT's parts
    (``nct_masks`` [F, K, H, W]: each object's inside; ``nct_background`` [H, W] where there is one),
    extra metrics and NeuralCT's trace (``method.TracePoint``s, empty unless ``trainer.snapshot_every_n_steps``).
    ``lap``: the run's stopwatch (`Phases.lap`), told as each phase ends (default: none)."""
    log.info("FBP: %d frames of %d x %d pixels ...", len(acq.frame_times), acq.grid.size, acq.grid.size)
    frames = {"fbp": fbp_frames(acq.sino, acq.grid, acq.frame_times, conf.fbp.window_deg, conf.fbp.filter)}
    lap("fbp")
    parts: dict[str, np.ndarray] = {}
    extra: dict = {}
    trace: list = []
    if conf.method == "nct":
        from nct.method.reconstruct import reconstruct

        log.info("NeuralCT: initialising (the FBP frames segmented, the starts judged on the views) ...")
        result = reconstruct(
            acq.sino, acq.grid, acq.frame_times, conf.model, conf.loss, conf.trainer, conf.seed,
            log_dir=out_dir, logger=conf.logger.name,
            fbp_filter=conf.fbp.filter, fbp_window_deg=conf.fbp.window_deg, n_objects=acq.n_objects,
            motion=conf.motion, optim=conf.optim, render=conf.render, init=conf.init, heldout=conf.heldout,
            background=conf.background,
            resume=conf.resume, lap=lap,
        )
        lap("refinement")
        frames["nct"] = result.frames
        parts["nct_masks"] = result.sdf > 0
        if result.background is not None:
            parts["nct_background"] = result.background
        extra = {"heldout_loss": result.heldout_loss, "heldout_se": result.heldout_se, "model": result.model, "selection": result.selection,
                 "stages": result.stages, "intensities": [float(a) for a in result.intensities], "init": result.init}
        trace = result.trace
    return frames, parts, extra, trace


def run(conf: NCTConf, cfg: DictConfig, out_dir: Path, started: Instant) -> tuple[dict, list[str]]:
    """Do one run into ``out_dir``; return what goes into ``metrics.json``, whose ``wall_time_s`` is
    the job's one wall time, from ``started`` to its outputs written, and ``phases`` where it went
    (`nct.run.phases`), and the run's warnings (a file's `slow_rotation_warning`, `determinacy_warnings`,
    `turn_warnings`, a file's `geometry_warnings`, `suspect_fit`)."""
    phases = Phases(started)
    import torch

    if conf.threads is not None:
        torch.set_num_threads(conf.threads)
    if conf.method == "nct":  # FBP draws no global random numbers (lazy: Lightning is ~3 s of start-up)
        import lightning

        lightning.seed_everything(conf.seed, workers=True, verbose=False)
    rng = np.random.default_rng(conf.seed)
    phases.lap("startup")
    acq = acquire(conf, rng)
    save_sinogram(out_dir / "sinogram.npz", acq.sino)
    phases.lap("data")
    motion = motion_determinacy(acq.sino, acq.grid)
    geometry = check_geometry(acq.sino)
    phases.lap("checks")
    frames, parts, extra, trace = reconstruct_all(conf, acq, out_dir, phases.lap)
    from_file = isinstance(conf.data, FileConf)  # a simulation's geometry and times are those that made its data
    warnings = ((slow_rotation_warning(acq.sino.angles, acq.sino.times, conf.data.times_unit) if from_file else [])
                + determinacy_warnings(motion) + turn_warnings(extra.get("init", {}))
                + (geometry_warnings(geometry, acq.sino, conf.suspect) if from_file else [])
                + suspect_fit(conf, acq, extra))
    phases.lap("checks")
    result: dict = {"times": acq.frame_times.tolist(), **extra,
                    "motion_determinacy": asdict(motion) if motion is not None else None,
                    "geometry_check": asdict(geometry) if geometry is not None else None}
    scored: dict[str, FrameMetrics] = {}
    if acq.sino.truth is not None:
        truth = acq.sino.truth
        scored = {name: frame_metrics(f, truth.frames, truth.level, truth.levels) for name, f in frames.items()}
        result.update({name: summarise(m) for name, m in scored.items()})
        if trace:
            result["trace"] = score_trace(trace, truth.frames, truth.level)
    elif trace:
        log.warning("trainer.snapshot_every_n_steps: the data hold no truth frames, so the run has no "
                    "Dice-against-time curve")
    phases.lap("metrics")
    log.info("writing the frames, pictures and movie ...")
    write_outputs(conf, acq, frames, parts, scored, result, out_dir)
    phases.lap("exports")
    result["phases"] = phases.record()
    result["wall_time_s"] = time.perf_counter() - started.wall  # TensorBoard's summary, written next, records it too
    if conf.logger.name == "tensorboard":
        write_summary(cfg, acq, frames, scored, result, out_dir)
    return result, warnings


def suspect_fit(conf: NCTConf, acq: Acquisition, extra: dict) -> list[str]:
    """The truth-free warnings on NeuralCT's fit (`nct.run.suspect`), none without one; adds FBP's and
    the noise's held-out misfits to ``extra`` (``heldout_fbp_loss``, ``heldout_noise_loss``)."""
    if "heldout_loss" not in extra:
        return []
    from nct.run.suspect import heldout_misfits, suspect_warnings

    misfits = heldout_misfits(acq.sino, acq.grid, extra["heldout_loss"], conf.heldout, conf.fbp)
    if misfits is None:
        return []
    extra |= {"heldout_fbp_loss": misfits.fbp, "heldout_noise_loss": misfits.noise}
    return suspect_warnings(misfits, conf.suspect, isinstance(conf.data, FileConf))


def score_trace(trace: list, truth: np.ndarray, level: float) -> list[dict]:
    """Each ``method.TracePoint``'s stage, step, seconds and median Dice and MSE against ``truth``
    [F, H, W]: the rows of ``trace.csv``."""
    rows = []
    for point in trace:
        s = summarise(frame_metrics(point.frames, truth, level))
        rows.append({"stage": point.stage, "step": point.step, "seconds": point.seconds,
                     "median_dice": s["median_dice"], "median_mse": s["median_mse"]})
    return rows


def write_outputs(conf: NCTConf, acq: Acquisition, frames: dict[str, np.ndarray], parts: dict[str, np.ndarray],
                  scored: dict[str, FrameMetrics], result: dict, out_dir: Path) -> None:
    """reconstruction.npz (the frames and NeuralCT's ``parts``), TIFF stacks, PNG strip, GIF and metric plot."""
    export.save_reconstruction(out_dir / "reconstruction.npz", acq.frame_times, acq.grid.extent, frames | parts)
    shown = _shown(acq, frames)
    if conf.export.tiff:
        export.save_tiffs(out_dir / "frames", shown, acq.frame_times, acq.grid.extent)
    if conf.export.png:
        export.save_strip(out_dir / "strip.png", shown, acq.frame_times, conf.export.strip_frames,
                          acq.grid.extent)
        if scored:
            export.save_metric_plot(out_dir / "metrics.png", acq.frame_times, scored)
        if "trace" in result:
            export.save_trace_plot(out_dir / "trace.png", result["trace"], result["fbp"]["median_dice"])
    if "trace" in result:
        write_csv(result["trace"], out_dir / "trace.csv")
    if "selection" in result:
        write_csv(result["selection"]["table"], out_dir / "selection.csv")
    if conf.export.gif:
        export.save_movie(out_dir / "movie.gif", shown, acq.frame_times, conf.export.fps, acq.grid.extent)


def _shown(acq: Acquisition, frames: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """The frames a run shows: the truth's first, when known."""
    return ({"truth": acq.sino.truth.frames} if acq.sino.truth is not None else {}) | frames


def write_summary(cfg: DictConfig, acq: Acquisition, frames: dict[str, np.ndarray],
                  scored: dict[str, FrameMetrics], result: dict, out_dir: Path) -> None:
    """The TensorBoard summary: final metrics and wall time as hparams, the selection table, trace, frames
    and where the time went (``phases``)."""
    final = {f"hp/{m}_{k}": result[m][k] for m in scored for k in ("median_dice", "median_mse")}
    final["hp/heldout_loss"] = result.get("heldout_loss", float("nan"))
    final["hp/wall_time_s"] = result["wall_time_s"]
    if "model" in result:
        final["hp/n_params"] = result["model"]["n_params"]
        write_selection(out_dir / "tb", result["model"], result["selection"])
    if "trace" in result:
        write_trace(out_dir / "tb", result["trace"])
    if result["motion_determinacy"] is not None:
        final["hp/motion_ray_spread_px"] = result["motion_determinacy"]["ray_spread_px"]
        write_motion(out_dir / "tb", result["motion_determinacy"])
    overrides = (read_status(out_dir) or {}).get("overrides", [])  # run_job records them before the run
    write_hparams(out_dir / "tb", run_hparams(cfg, overrides), final)
    write_phases(out_dir / "tb", result["phases"], result.get("stages", {}))
    write_frames(out_dir / "tb", _shown(acq, frames))
