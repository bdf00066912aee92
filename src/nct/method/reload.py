"""A finished reconstruction's fitted field, rendered at any times and resolution.

The field g(x, t) is a continuous function of space and time; a run samples it only at its own
frame times on its own grid. ``load_run`` checks a run folder and reads its field file
(method/fitted.py: ``checkpoints/field.pt``, the same file `nct.load` reads), and ``render`` draws
intensity and SDF frames from it exactly as ``method.reconstruct`` does, so at the run's own times
and grid it gives the run's own frames.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch
from omegaconf import OmegaConf

from nct.acquisition.scanner import ImageGrid
from nct.errors import InputError
from nct.fit.conf import OptimConf
from nct.fit.render import intensity
from nct.fit.stages import FieldStage
from nct.method.fitted import FIELD_FILE, FittedField, load_field
from nct.method.reconstruct import field_frames


@dataclass(frozen=True)
class FittedRun:
    """A finished run's fitted field (``fitted``) and its movie frame rate (``fps``, config export.fps)."""

    fitted: FittedField
    fps: float


def even_times(span: tuple[float, float], n: int) -> np.ndarray:
    """``n`` times evenly spread over ``span``, centred in their slots (as ``Scanner.frame_times``): [n]."""
    start, end = span
    return start + (np.arange(n) + 0.5) * ((end - start) / n)


def load_run(run_dir: Path) -> FittedRun:
    """The fitted field of the finished NeuralCT run in ``run_dir``; ``InputError`` saying why when the
    folder is no run, an FBP-only run, unfinished or without its field file."""
    run_dir = Path(run_dir)
    config, status = run_dir / ".hydra" / "config.yaml", run_dir / "status.json"
    if not (config.is_file() and status.is_file()):
        raise InputError(f"{run_dir} is not a run folder (no .hydra/config.yaml and status.json)")
    cfg = OmegaConf.load(config)
    if cfg.get("method") == "fbp":
        raise InputError(f"{run_dir} is an FBP-only run (method=fbp): it fitted no field to render")
    state = json.loads(status.read_text()).get("status")
    if state != "ok":
        raise InputError(f"{run_dir} did not finish (status.json: {state}): nothing to render")
    return FittedRun(load_field(run_dir / FIELD_FILE), float(cfg.export.fps))


def check_times(span: tuple[float, float], times: np.ndarray, key: str) -> None:
    """`InputError` naming ``key`` when one of ``times`` [T] (s) lies outside the acquisition ``span``."""
    start, end = span
    outside = [float(t) for t in times if not start <= t <= end]
    if outside:
        raise InputError(f"{key} {outside[0]:g} lies outside the acquisition, {start:g} s to {end:g} s")


def render(run: FittedField, times: np.ndarray, size: int) -> tuple[np.ndarray, np.ndarray]:
    """Intensity frames [T, size, size] and SDF frames [T, K, size, size] (float32, data units) at
    ``times`` [T] (s) over the reconstruction's field of view.

    The occupancy ramp keeps the physical width the fit used (``render.band_px`` pixels of the
    run's grid), whatever ``size``: the fitted image is b + sum_k a(k) zeta(g_k) with that ramp (b:
    the static background, if any, resampled bilinearly), and every size samples that one image
    (a ramp of band_px new pixels would sharpen or blur it). The field is drawn as its last stage drew it, on
    ``run.lattice``^2 points interpolated bilinearly, so the run's own times and size give its own frames.
    """
    band = run.render.band_px * run.units.grid(run.grid).pixel_size
    grid = run.units.grid(ImageGrid(size, run.grid.extent))
    sdf = field_frames(FieldStage(run.field, grid, OptimConf(), run.lattice), run.clock(times))
    background = None if run.field.background is None else run.field.background.detach()
    frames = intensity(torch.from_numpy(sdf), run.field.intensities.detach(), band, run.render.mu, background).numpy()
    frames, sdf = frames * run.units.intensity, sdf * run.units.length
    return frames.astype(np.float32), sdf.astype(np.float32)
