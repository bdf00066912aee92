"""One run, end to end: data (a `Scan`) -> FBP -> NeuralCT -> metrics -> files and TensorBoard.

`nct.run.job.run_job` validates the config, records the run's status and calls `run`, which reconstructs
through `nct.run.reconstruct.reconstruct_scan`, the path `nct.reconstruct` takes from Python, and writes
the run folder from the `Reconstruction` it returns.
"""

from __future__ import annotations

import logging
import time
from pathlib import Path

import numpy as np
from omegaconf import DictConfig

from nct.acquisition.io import save_sinogram
from nct.acquisition.scan import Scan, output_grid
from nct.run import export
from nct.run.conf import FileConf
from nct.run.folder import read_status
from nct.run.memory import RunSize, check_memory
from nct.run.metrics import FrameMetrics, frame_metrics, summarise
from nct.run.phases import Instant, Phases
from nct.run.reconstruct import reconstruct_scan
from nct.run.reconstruction import Reconstruction
from nct.run.schema import NCTConf
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


def acquire(conf: NCTConf, rng: np.random.Generator) -> Scan:
    """Simulate the configured scene or load the sinogram file (frames on its truth grid if it has
    one, else ``image.size`` pixels over ``data.extent``: `output_grid`); a file's sizes are checked
    against the memory here (a simulation's in `validate`)."""
    if isinstance(conf.data, FileConf):
        log.info("reading %s ...", conf.data.path)
        scan = Scan.from_file(conf.data.path, conf.data.sidecar, conf.data.times_unit, i0=conf.data.i0,
                              size=conf.image.size, extent=conf.data.extent,
                              frames_per_rotation=conf.image.frames_per_rotation)
        image_key = (f"data.path={conf.data.path} (its truth frames)" if scan.truth is not None
                     else f"image.size={conf.image.size}")
        check_memory(conf, RunSize(scan.grid.size, len(scan.frame_times), *scan.sinogram.values.shape), image_key,
                     f"data.path={conf.data.path}")
        return scan
    scanner = conf.scanner.build(conf.image.extent)
    phantom = build_phantom(conf.phantom, scanner.rotation_time)
    log.info("simulating the %s phantom: %d views of %d bins ...", conf.phantom.name, scanner.n_views,
             conf.scanner.n_bins)
    sino = simulate(phantom, scanner, conf.image.build(), scanner.frame_times(conf.image.frames_per_rotation),
                    conf.data.noise_i0, rng)
    return Scan.of(sino, *output_grid(sino), simulated=True)  # the truth's grid and times: those simulated


def run(conf: NCTConf, cfg: DictConfig, out_dir: Path, started: Instant) -> tuple[dict, list[str]]:
    """Do one run into ``out_dir``; return what goes into ``metrics.json``, whose ``wall_time_s`` is
    the job's one wall time, from ``started`` to its outputs written, and ``phases`` where it went
    (`nct.run.phases`), and the run's warnings (`nct.run.reconstruct.reconstruct_scan`'s)."""
    phases = Phases(started)
    if conf.method == "nct":  # loaded with the rest of the start-up (lazy: FBP alone needs none of it)
        import lightning  # noqa: F401
    phases.lap("startup")
    scan = acquire(conf, np.random.default_rng(conf.seed))
    save_sinogram(out_dir / "sinogram.npz", scan.sinogram)
    phases.lap("data")
    rec = reconstruct_scan(scan, conf, out_dir, phases.lap)
    result = dict(rec.record)
    scored: dict[str, FrameMetrics] = {}
    if scan.truth is not None:
        truth = scan.truth
        scored = rec.metrics()
        result.update({name: summarise(m) for name, m in scored.items()})
        if rec.trace:
            result["trace"] = score_trace(rec.trace, truth.frames, truth.level)
    elif rec.trace:
        log.warning("callbacks.snapshot_every_n_steps: the data hold no truth frames, so the run has no "
                    "Dice-against-time curve")
    phases.lap("metrics")
    log.info("writing the frames, pictures and movie ...")
    write_outputs(conf, rec, scored, result, out_dir)
    phases.lap("exports")
    result["phases"] = phases.record()
    result["wall_time_s"] = time.perf_counter() - started.wall  # TensorBoard's summary, written next, records it too
    if conf.logger.name == "tensorboard":
        write_summary(cfg, rec, scored, result, out_dir)
    return result, rec.warnings


def score_trace(trace: list, truth: np.ndarray, level: float) -> list[dict]:
    """Each ``method.TracePoint``'s stage, step, seconds and median Dice and MSE against ``truth``
    [F, H, W]: the rows of ``trace.csv``."""
    rows = []
    for point in trace:
        s = summarise(frame_metrics(point.frames, truth, level))
        rows.append({"stage": point.stage, "step": point.step, "seconds": point.seconds,
                     "median_dice": s["median_dice"], "median_mse": s["median_mse"]})
    return rows


def write_outputs(conf: NCTConf, rec: Reconstruction, scored: dict[str, FrameMetrics], result: dict,
                  out_dir: Path) -> None:
    """The reconstruction's files (`Reconstruction.write`: reconstruction.npz, selection.csv, its record and
    field), TIFF stacks, PNG strip, GIF and metric plot."""
    rec.write(out_dir)
    shown, times, extent = _shown(rec), rec.times, rec.extent
    if conf.export.tiff:
        export.save_tiffs(out_dir / "frames", shown, times, extent)
    if conf.export.png:
        export.save_strip(out_dir / "strip.png", shown, times, conf.export.strip_frames, extent)
        if scored:
            export.save_metric_plot(out_dir / "metrics.png", times, scored)
        if "trace" in result:
            export.save_trace_plot(out_dir / "trace.png", result["trace"], result["fbp"]["median_dice"])
    if "trace" in result:
        write_csv(result["trace"], out_dir / "trace.csv")
    if conf.export.gif:
        export.save_movie(out_dir / "movie.gif", shown, times, conf.export.fps, extent)


def _shown(rec: Reconstruction) -> dict[str, np.ndarray]:
    """The frames a run shows: the truth's first, when known."""
    return ({"truth": rec.scan.truth.frames} if rec.scan.truth is not None else {}) | rec.methods()


def write_summary(cfg: DictConfig, rec: Reconstruction, scored: dict[str, FrameMetrics], result: dict,
                  out_dir: Path) -> None:
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
    write_frames(out_dir / "tb", _shown(rec))
