"""The one way from a `Scan` to a `Reconstruction`: checks of the data, FBP, NeuralCT, the truth-free warnings.

`nct.reconstruct` (api.py) and the ``nct`` command (run/pipeline.py) both call `reconstruct_scan`, so a
sinogram gives the same frames from Python and from the command line.
"""

from __future__ import annotations

import json
import logging
from collections.abc import Callable
from dataclasses import asdict, replace
from pathlib import Path

import numpy as np

from nct.acquisition.scan import Scan
from nct.acquisition.times import slow_rotation_warning
from nct.fit.conf import TrainerConf
from nct.moments.determinacy import (
    determinacy_warnings,
    motion_determinacy,
    turn_coverage,
    turn_warnings,
)
from nct.physics.fbp import fbp_frames
from nct.run.conf import chosen_objects
from nct.run.consistency import check_geometry, geometry_warnings
from nct.run.reconstruction import Reconstruction
from nct.run.schema import NCTConf

log = logging.getLogger(__name__)


def reconstruct_scan(scan: Scan, conf: NCTConf, log_dir: Path | None = None,
                     lap: Callable[[str], None] = lambda phase: None) -> Reconstruction:
    """FBP, and NeuralCT unless ``method=fbp``, of ``scan`` with the settings ``conf`` (torch's threads
    ``conf.threads`` where set, every random stream seeded from ``conf.seed``); the data's checks and
    the run's warnings (a measured scan's times and geometry too; a simulation's are those that made it).
    ``log_dir``: where the fits write their checkpoints and logs (None: nowhere); ``lap``: the run's
    stopwatch (`Phases.lap`), told as each phase ends."""
    import torch

    if conf.threads is not None:
        torch.set_num_threads(conf.threads)
    if conf.method == "nct":  # FBP draws no global random numbers (lazy: Lightning is ~3 s of start-up)
        import lightning

        lightning.seed_everything(conf.seed, workers=True, verbose=False)
    sino, grid = scan.sinogram, scan.grid
    motion, turn, geometry = motion_determinacy(sino, grid), turn_coverage(sino), check_geometry(sino)
    lap("checks")
    log.info("FBP: %d frames of %d x %d pixels ...", len(scan.frame_times), grid.size, grid.size)
    fbp = fbp_frames(sino, grid, scan.frame_times, conf.fbp.window_deg, conf.fbp.filter).astype(np.float32, copy=False)
    lap("fbp")
    rec = Reconstruction(scan, fbp) if conf.method != "nct" else _neuralct(scan, conf, fbp, log_dir, lap)
    measured = not scan.simulated
    rec.warnings = ((slow_rotation_warning(sino.angles, sino.times, scan.times_unit) if measured else [])
                    + determinacy_warnings(motion) + turn_warnings(turn)
                    + (geometry_warnings(geometry, sino, conf.suspect) if measured else [])
                    + suspect_fit(conf, rec.record, measured))
    lap("checks")
    record = {"times": scan.frame_times.tolist(), **rec.record,
              "motion_determinacy": asdict(motion) if motion is not None else None, "turn_coverage_deg": turn,
              "geometry_check": asdict(geometry) if geometry is not None else None}
    rec.record = json.loads(json.dumps(record))  # plain JSON values, as metrics.json and a saved one hold them
    return rec


def _neuralct(scan: Scan, conf: NCTConf, fbp: np.ndarray, log_dir: Path | None,
              lap: Callable[[str], None]) -> Reconstruction:
    """NeuralCT's frames, parts and record beside the FBP frames ``fbp`` (method/reconstruct.py), fitted to
    ``scan.to_fit(optim.fit_size)`` (``scan`` itself, or its views binned) and drawn on ``scan``'s grid."""
    import torch

    from nct.fit.render import resampled
    from nct.method.reconstruct import reconstruct
    from nct.method.reload import render

    fitted = scan.to_fit(conf.optim.fit_size)
    if fitted is not scan:
        log.info("NeuralCT: fitted to the views binned to %d bins on %d x %d pixels (optim.fit_size=%d), its field "
                 "drawn at %d x %d", fitted.sinogram.n_bins, fitted.grid.size, fitted.grid.size, conf.optim.fit_size,
                 scan.grid.size, scan.grid.size)
    log.info("NeuralCT: initialising (the FBP frames segmented, the starts judged on the views) ...")
    trainer = TrainerConf(conf.trainer, conf.callbacks)  # each stage's Trainer: its arguments and callbacks
    result = reconstruct(
        fitted.sinogram, fitted.grid, scan.frame_times, conf.model, conf.loss, trainer, conf.seed,
        log_dir=log_dir, logger=conf.logger.name,
        fbp_filter=conf.fbp.filter, fbp_window_deg=conf.fbp.window_deg, n_objects=chosen_objects(conf.data.n_objects),
        motion=conf.motion, optim=conf.optim, render=conf.render, init=conf.init, heldout=conf.heldout,
        background=conf.background,
        resume=conf.resume, lap=lap,
    )
    lap("refinement")
    record = {"heldout_loss": result.heldout_loss, "heldout_se": result.heldout_se, "model": result.model,
              "selection": result.selection, "stages": result.stages,
              "intensities": [float(a) for a in result.intensities], "init": result.init}
    if fitted is not scan:
        record["fitted_on"] = {"n_bins": fitted.sinogram.n_bins, "size": fitted.grid.size}
    if result.misfits is not None:  # the suspect-fit warnings' (suspect_fit)
        record |= {"heldout_fbp_loss": result.misfits.fbp, "heldout_noise_loss": result.misfits.noise}
    if fitted is scan:
        return Reconstruction(scan, fbp, result.frames, result.sdf > 0, result.background, record=record,
                              fitted=result.fitted, trace=result.trace)
    frames, sdf = render(result.fitted, scan.frame_times, scan.grid.size)  # the field drawn at the image's size

    def drawn(images: np.ndarray) -> np.ndarray:  # [N, h, w] resampled as a drawn field's background is
        return resampled(torch.from_numpy(np.ascontiguousarray(images)), (scan.grid.size,) * 2).numpy()

    trace = [replace(point, frames=drawn(point.frames)) for point in result.trace]
    background = None if result.background is None else drawn(result.background[None])[0]
    return Reconstruction(scan, fbp, frames, sdf > 0, background, record=record, fitted=result.fitted, trace=trace)


def suspect_fit(conf: NCTConf, record: dict, from_file: bool) -> list[str]:
    """The truth-free warnings on NeuralCT's fit (`nct.run.suspect`) from its held-out misfits in its ``record``
    (FBP's and the noise's, the method's: none without held-out views or without a fit); ``from_file``: the data
    came from a file."""
    if "heldout_fbp_loss" not in record:
        return []
    from nct.run.suspect import suspect_warnings
    from nct.select.misfits import HeldoutMisfits

    misfits = HeldoutMisfits(record["heldout_loss"], record["heldout_fbp_loss"], record["heldout_noise_loss"])
    return suspect_warnings(misfits, conf.suspect, from_file)
