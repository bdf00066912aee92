"""A finished run's fitted field, rebuilt from its checkpoint and rendered at any times and resolution.

The field g(x, t) is a continuous function of space and time; a run samples it only at its own
frame times on its own grid. ``load_run`` rebuilds the field from the run folder alone (its Hydra
config, ``metrics.json``, ``sinogram.npz`` and the last stage checkpoint of the chosen model,
loaded with ``weights_only``), and ``render`` draws intensity and SDF frames from it exactly as
``method.reconstruct`` does, so at the run's own times and grid it gives the run's own frames.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch
from omegaconf import DictConfig, OmegaConf

from nct.acquisition.io import load_sinogram
from nct.acquisition.scanner import ImageGrid
from nct.errors import InputError
from nct.fields.base import SpaceTimeField
from nct.fields.build import build_field
from nct.fields.conf import ModelConf
from nct.fit.conf import OptimConf, RenderConf
from nct.fit.problem import rotations_since_start, rotations_spanned
from nct.fit.render import intensity
from nct.fit.stages import FieldStage
from nct.fit.units import Units
from nct.method.reconstruct import field_frames

# A field saved before fields could turn (session 40), turn one part of several (41) or hold a darker
# nested object (42) renders as fitted
LATER_STATE = ("turn", "turned", "turned_object", "signs")


@dataclass(frozen=True)
class FittedRun:
    """What rendering a run's field needs.

    field: the fitted field with its a(k) (method units); units: the
    run's units (fit/units.py); grid: the run's own grid (data units); clock: seconds ->
    rotations since the first view; span: (first, last) second of the acquisition; render: the
    run's occupancy settings; fps: the run's movie frame rate; checkpoint: the file loaded.
    """

    field: SpaceTimeField
    units: Units
    grid: ImageGrid
    clock: Callable[[np.ndarray], torch.Tensor]
    span: tuple[float, float]
    render: RenderConf
    fps: float
    checkpoint: Path


def acquisition_span(times: np.ndarray) -> tuple[float, float]:
    """First and last second of an acquisition with views at ``times`` [V]: each view lasts until
    the next and the last one as long as the median, so a run's frame times (centred in their
    slots of the acquisition) always lie inside."""
    step = float(np.median(np.diff(times))) if len(times) > 1 else 0.0
    return float(times[0]), float(times[-1]) + step


def even_times(span: tuple[float, float], n: int) -> np.ndarray:
    """``n`` times evenly spread over ``span``, centred in their slots (as ``Scanner.frame_times``): [n]."""
    start, end = span
    return start + (np.arange(n) + 0.5) * ((end - start) / n)


def _typed(schema: type, node: DictConfig):
    """A config group of the run's saved config as its schema's dataclass (range checks run)."""
    return OmegaConf.to_object(OmegaConf.merge(OmegaConf.structured(schema), node))


def _read_json(path: Path) -> dict:
    return json.loads(path.read_text())


def _checkpoint(run_dir: Path, stages: dict, winner: str) -> Path:
    """The last saved stage checkpoint of the chosen field: the refinement's if any, else the
    tournament winner's (metrics.json -> selection -> winner; selection.csv)."""
    ours = [s for s in (f"{winner}_fit", "refine_init", "refine_fit") if s in stages]
    saved = [run_dir / "checkpoints" / s / "last.ckpt" for s in ours]
    saved = [p for p in saved if p.is_file()]
    if not saved:
        raise InputError(f"{run_dir} holds no checkpoint of its fitted field (checkpoints/<stage>/last.ckpt)")
    return saved[-1]


def load_run(run_dir: Path) -> FittedRun:
    """Rebuild the fitted field of the finished NeuralCT run in ``run_dir``; ``InputError`` saying
    why when the folder is no run, an FBP-only run, unfinished or without a checkpoint."""
    run_dir = Path(run_dir)
    config, status = run_dir / ".hydra" / "config.yaml", run_dir / "status.json"
    if not (config.is_file() and status.is_file()):
        raise InputError(f"{run_dir} is not a run folder (no .hydra/config.yaml and status.json)")
    cfg = OmegaConf.load(config)
    if cfg.get("method") == "fbp":
        raise InputError(f"{run_dir} is an FBP-only run (method=fbp): it fitted no field to render")
    state = _read_json(status).get("status")
    if state != "ok":
        raise InputError(f"{run_dir} did not finish (status.json: {state}): nothing to render")
    metrics = _read_json(run_dir / "metrics.json")
    if "selection" not in metrics:
        raise InputError(f"{run_dir} was written by an older nct (metrics.json has no selection): rerun it")
    model: ModelConf = _typed(ModelConf, cfg.model)
    path = _checkpoint(run_dir, metrics["stages"], metrics["selection"]["winner"])
    # The winner's own construction (method.reconstruct); every tensor, the frequencies ``omega``
    # included, is then restored from the checkpoint.
    sino = load_sinogram(run_dir / "sinogram.npz")
    net = build_field(model, len(metrics["intensities"]), torch.Generator(), metrics["model"]["motion"],
                      rotations_spanned(sino))
    weights = torch.load(path, map_location="cpu", weights_only=True)["state_dict"]
    weights = {k.removeprefix("field."): v for k, v in weights.items() if k.startswith("field.")}
    if "background" in weights:
        net.set_background(weights["background"])
    weights = {**{k: v for k, v in net.state_dict().items() if k in LATER_STATE}, **weights}
    missing = sorted(set(net.state_dict()) - set(weights))
    if missing:
        raise InputError(f"{run_dir} was written by an older nct (its checkpoint has no {', '.join(missing)}): "
                         "rerun it")
    net.load_state_dict(weights)
    net.eval()
    units = Units(metrics["init"]["length_unit"], metrics["init"]["intensity_unit"])
    with np.load(run_dir / "reconstruction.npz") as rec:
        grid = ImageGrid(int(rec["nct"].shape[-1]), float(rec["extent"]))
    return FittedRun(net, units, grid, rotations_since_start(sino), acquisition_span(sino.times),
                     _typed(RenderConf, cfg.render), float(cfg.export.fps), path)


def render(run: FittedRun, times: np.ndarray, size: int) -> tuple[np.ndarray, np.ndarray]:
    """Intensity frames [T, size, size] and SDF frames [T, K, size, size] (float32, data units) at
    ``times`` [T] (s) over the run's field of view.

    The occupancy ramp keeps the physical width the fit used (``render.band_px`` pixels of the
    run's grid), whatever ``size``: the fitted image is b + sum_k a(k) zeta(g_k) with that ramp (b:
    the static background, if any, resampled bilinearly), and every size samples that one image
    (a ramp of band_px new pixels would sharpen or blur it).
    """
    band = run.render.band_px * run.units.grid(run.grid).pixel_size
    grid = run.units.grid(ImageGrid(size, run.grid.extent))
    sdf = field_frames(FieldStage(run.field, grid, OptimConf()), run.clock(times))
    background = None if run.field.background is None else run.field.background.detach()
    frames = intensity(torch.from_numpy(sdf), run.field.intensities.detach(), band, run.render.mu, background).numpy()
    frames, sdf = frames * run.units.intensity, sdf * run.units.length
    return frames.astype(np.float32), sdf.astype(np.float32)
