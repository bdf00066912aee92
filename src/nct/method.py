"""NeuralCT end to end (Algorithms 1-6 and refinement): a sinogram in, intensity frames out."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from nct.fields import ModelConf
from nct.scanner import ImageGrid
from nct.sinogram import Sinogram
from nct.stages import LossConf, TrainerConf


@dataclass
class NCTResult:
    """What ``reconstruct`` returns.

    frames: [F, H, W] float32 intensity sum_k a(k) zeta_k; sdf: [F, K, H, W] float32;
    intensities: [K] estimated from the data; heldout_loss: sinogram L1 on held-out views;
    stages: per stage {steps, losses, wall_time_s}; capacity: description of the model.
    """

    frames: np.ndarray
    sdf: np.ndarray
    intensities: np.ndarray
    heldout_loss: float
    stages: dict = field(default_factory=dict)
    capacity: dict = field(default_factory=dict)


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
) -> NCTResult:
    """Reconstruct intensity frames at ``frame_times`` [F] on ``grid``; never reads ``sino.truth``."""
    raise NotImplementedError("nct.method.reconstruct is being written (issue 3)")
