"""The callbacks of a stage's Trainer that stop or watch it (the stages only optimise): the early stops
(`MinLossStop`, `HeldoutStop`), the divergence check, and the TensorBoard images drawn from the stage's
field (`ImageLog`). The snapshots of the Dice-against-time curve are ``trainer.py``'s `SnapshotLog`;
the progress bar and lines ``progress.py``'s."""

from __future__ import annotations

import math
from collections.abc import Callable

import torch
from lightning.pytorch.callbacks import Callback
from torch import Tensor

from nct.errors import DivergenceError
from nct.fit.problem import HeldoutHistory
from nct.fit.render import intensity
from nct.fit.stages import FieldStage, InitFit, SinogramFit, logging_step


class MinLossStop(Callback):
    """Stop SinogramFit once its sinogram loss falls below ``min_loss`` (Algorithm 4's minLoss)."""

    def __init__(self, min_loss: float) -> None:
        self.min_loss = min_loss

    def on_train_batch_end(self, trainer, pl_module, outputs, batch, batch_idx) -> None:
        if self.min_loss > 0 and float(outputs["sinogram"]) < self.min_loss:
            trainer.should_stop = True


class HeldoutStop(Callback):
    """Stop SinogramFit after a validation once ``stops`` says so from its held-out history
    [(step, loss)] so far (the tournament's rule, select/tournament.py)."""

    def __init__(self, stops: Callable[[HeldoutHistory], bool]) -> None:
        self.stops = stops

    def on_validation_end(self, trainer, pl_module) -> None:
        if self.stops(pl_module.heldout_history):
            trainer.should_stop = True


class DivergenceCheck(Callback):
    """Raise DivergenceError on a non-finite loss or one above ``factor`` x the stage's first loss.
    Checked on the Trainer's logging steps and the last: reading a loss makes the host wait for
    the device, so not every step."""

    def __init__(self, stage: str, factor: float) -> None:
        self.stage, self.factor, self.first = stage, factor, None

    def on_train_batch_end(self, trainer, pl_module, outputs, batch, batch_idx) -> None:
        loss = (outputs["loss"] if isinstance(outputs, dict) else outputs).detach()
        self.first = loss if self.first is None else self.first
        if not logging_step(trainer, batch_idx):
            return
        loss, first = float(loss), float(self.first)
        if not math.isfinite(loss) or loss > self.factor * first:
            lr = trainer.optimizers[0].param_groups[0]["lr"]
            raise DivergenceError(
                f"stage '{self.stage}' diverged at step {trainer.global_step}: loss {loss:.4g} (first step "
                f"{first:.4g}, limit {self.factor:g}x) at learning rate {lr:.3g}; "
                "lower optim.lr or raise optim.warmup_steps"
            )


def evenly(times: Tensor, n: int) -> Tensor:
    """Indices of n evenly spaced entries of ``times`` [T]."""
    return torch.linspace(0, times.shape[0] - 1, n).round().long().to(times.device)


@torch.no_grad()
def init_preview(stage: InitFit, n: int) -> Tensor:
    """Target | fitted SDF > 0 at n evenly spaced target times: [2, n, H, W] in [0, 1]."""
    pick = evenly(stage.times, n)
    sdf = stage.grid_sdf(stage.times[pick])
    return torch.stack([(stage.targets[pick] > 0).any(1), (sdf > 0).any(1)]).float()


@torch.no_grad()
def fit_preview(stage: SinogramFit, n: int) -> Tensor:
    """Intensity frames at n evenly spaced view times, at the current band: [1, n, H, W]."""
    sdf = stage.grid_sdf(stage.times[evenly(stage.times, n)])
    return intensity(sdf, stage.intensities, stage.band(), stage.render_conf.mu)[None]


@torch.no_grad()
def fit_residual(stage: SinogramFit, n: int) -> Tensor:
    """Rendered minus measured sinogram at n evenly spaced views, over the data's max: [n, n_bins]."""
    pick = evenly(stage.times, n)
    sdf = stage.grid_sdf(stage.times[pick])
    return (stage.render(sdf, pick, stage.band()) - stage.values[pick]) / stage.values.abs().max().clamp_min(1e-12)


class ImageLog(Callback):
    """Every ``every`` steps (and at the end), frames over time and (SinogramFit) the sinogram
    residual to TensorBoard, rendered from the stage's field; the stages only optimise."""

    def __init__(self, stage: str, every: int, n_frames: int = 8, n_views: int = 90) -> None:
        self.stage, self.every, self.n_frames, self.n_views = stage, every, n_frames, n_views

    def on_train_batch_end(self, trainer, pl_module, outputs, batch, batch_idx) -> None:
        if trainer.global_step % self.every == 0 or trainer.global_step >= trainer.max_steps:
            self.log_images(trainer, pl_module)

    def log_images(self, trainer, pl_module: FieldStage) -> None:
        writer = trainer.logger.experiment
        fitting = isinstance(pl_module, SinogramFit)
        rows = (fit_preview if fitting else init_preview)(pl_module, self.n_frames)  # [R, n, H, W]
        strip = torch.cat([torch.cat(list(row), dim=1) for row in rows], dim=0)
        top = float(strip.max().clamp_min(1e-6))
        writer.add_image(f"{self.stage}/frames", (strip / top).clamp(0, 1)[None], trainer.global_step)
        if fitting:
            res = fit_residual(pl_module, self.n_views)
            writer.add_image(f"{self.stage}/sinogram_residual", (0.5 + 0.5 * res).clamp(0, 1)[None],
                             trainer.global_step)
