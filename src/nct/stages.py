"""The optimisation stages of NeuralCT: InitFit (Algorithm 3) and SinogramFit (Algorithm 4).

Both stages evaluate the field's networks once per step on the whole grid and form the SDF at
every sampled time through the Fourier basis; spatial derivatives (Eikonal, TV) are finite
differences on the grid. The modules only optimise; data, export and metrics live elsewhere.
"""

from __future__ import annotations

import logging
import math
import sys
import time
import warnings
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

import lightning as L
import numpy as np
import torch
from lightning.pytorch.callbacks import Callback, LearningRateMonitor
from lightning.pytorch.loggers import CSVLogger, TensorBoardLogger
from torch import Tensor
from torch.utils.data import DataLoader, IterableDataset

from nct.errors import DivergenceError
from nct.fields import Field, require
from nct.geometry import Geometry
from nct.render import intensity, occupancy, project_frames
from nct.scanner import ImageGrid

LOGGERS = ("tensorboard", "csv", "none")


@dataclass
class LossConf:
    """Loss weights (config group ``loss``).

    The paper numbers its weights two ways: Algorithm 4 has lambda1 Eikonal, lambda2 TV space,
    lambda3 TV time; Sections V-VI call TV space lambda1 and TV time lambda2. Here they are named.
    eikonal: weight of mean | |grad_x g| - 1 | in SinogramFit (keeps g a distance, so a shift of
        the boundary moves the whole field with it).
    tv_space: weight of mean(|dg/dx| + |dg/dy|) (dimensionless).
    tv_time: weight of mean |dg/dt|, g in field-of-view sides and t in gantry rotations.
    init_eikonal: weight of the Eikonal term in InitFit (Algorithm 3's lambda).
    The sinogram term is the L1 misfit relative to the data's mean |value|; InitFit's SDF term is
    the L1 misfit in pixels.
    """

    name: str = "default"
    eikonal: float = 1.0
    tv_space: float = 0.0
    tv_time: float = 0.0
    init_eikonal: float = 0.1

    def __post_init__(self) -> None:
        for key in ("eikonal", "tv_space", "tv_time", "init_eikonal"):
            require(getattr(self, key) >= 0, f"loss.{key}", ">= 0", getattr(self, key))


@dataclass
class TrainerConf:
    """How the stages run (config group ``trainer``).

    accelerator, devices: passed to Lightning. init_steps, fit_steps: steps of InitFit and
    SinogramFit in the first pass. lr: Adam's rate, reached after warmup_steps, then multiplied
    by lr_decay every lr_decay_every steps; the sinogram fit needs the decay: at a constant 1e-3
    it wanders off even a start from the true SDF. refine: run the second pass (Algorithms 2-6
    again) on the first pass's field, refine_init_steps and refine_fit_steps at refine_lr with
    the final band. batch_views: views (timepoints) per step.
    min_loss: stop SinogramFit once the sinogram loss is below (0: never).
    fit_intensities: SinogramFit also fits a(k), from Algorithm 1's estimate, at intensity_lr
    (Adam on log a): FBP of fast motion has no histogram peak at the object's level.
    band_px: width in pixels of the occupancy ramp (see render.py); SinogramFit starts at
    band_start_px and narrows geometrically to band_px over band_anneal of its steps, so that at
    first a wide band of the boundary gets gradient. mu: the paper's occupancy slope.
    k_samp: supersampling of the render. init_frames_per_rotation: SDF frames InitFit fits.
    kappa, gmm_share: Algorithm 1's buffer classes and share of frames for the mixture.
    heldout_every: every n-th view is held out of the fit and scores it (0: none).
    divergence_factor: stop with DivergenceError once a loss exceeds this multiple of its start.
    progress_bar: None shows it when stdout is a terminal. log_every_n_steps: scalars;
    image_every_n_steps: frame and residual images in TensorBoard.
    """

    name: str = "cpu"
    accelerator: str = "auto"
    devices: int = 1
    init_steps: int = 300
    fit_steps: int = 1000
    refine: bool = True
    refine_init_steps: int = 100
    refine_fit_steps: int = 300
    refine_lr: float = 1e-4
    lr: float = 1e-3
    warmup_steps: int = 50
    lr_decay: float = 0.65
    lr_decay_every: int = 100
    batch_views: int = 20
    min_loss: float = 0.0
    fit_intensities: bool = True
    intensity_lr: float = 1e-2
    band_px: float = 1.0
    band_start_px: float = 4.0
    band_anneal: float = 0.6
    mu: float = 50.0
    k_samp: int = 1
    init_frames_per_rotation: int = 60
    kappa: int = 3
    gmm_share: float = 0.02
    heldout_every: int = 10
    divergence_factor: float = 20.0
    progress_bar: bool | None = None
    log_every_n_steps: int = 10
    image_every_n_steps: int = 200

    def __post_init__(self) -> None:
        positive_ints = ("devices", "lr_decay_every", "batch_views", "k_samp", "init_frames_per_rotation",
                         "log_every_n_steps", "image_every_n_steps")
        for key in positive_ints:
            require(getattr(self, key) >= 1, f"trainer.{key}", ">= 1", getattr(self, key))
        for key in ("init_steps", "fit_steps", "refine_init_steps", "refine_fit_steps", "warmup_steps",
                    "min_loss", "kappa", "heldout_every"):
            require(getattr(self, key) >= 0, f"trainer.{key}", ">= 0", getattr(self, key))
        require(self.lr > 0, "trainer.lr", "> 0", self.lr)
        require(self.refine_lr > 0, "trainer.refine_lr", "> 0", self.refine_lr)
        require(self.intensity_lr > 0, "trainer.intensity_lr", "> 0", self.intensity_lr)
        require(0 < self.lr_decay <= 1, "trainer.lr_decay", "in (0, 1]", self.lr_decay)
        require(self.band_px > 0, "trainer.band_px", "> 0", self.band_px)
        require(self.band_start_px >= self.band_px, "trainer.band_start_px", ">= trainer.band_px",
                self.band_start_px)
        require(0 <= self.band_anneal <= 1, "trainer.band_anneal", "in [0, 1]", self.band_anneal)
        require(self.mu > 2, "trainer.mu", "> 2", self.mu)
        require(0 < self.gmm_share <= 1, "trainer.gmm_share", "in (0, 1]", self.gmm_share)
        require(self.divergence_factor > 1, "trainer.divergence_factor", "> 1", self.divergence_factor)


@dataclass(frozen=True)
class Views:
    """Measured views as tensors: values [V, n_bins], angles [V] rad, times [V] in rotations; the rays' geometry."""

    values: Tensor
    angles: Tensor
    times: Tensor
    geometry: Geometry

    @property
    def scale(self) -> float:
        """Mean |value|: the sinogram loss is relative to it."""
        return float(self.values.abs().mean().clamp_min(1e-12))


def spatial_gradient(sdf: Tensor, pixel_size: float) -> tuple[Tensor, Tensor]:
    """Forward differences dg/dx, dg/dy on the grid: [..., H, W] -> two [..., H-1, W-1]."""
    gx = (sdf[..., :-1, 1:] - sdf[..., :-1, :-1]) / pixel_size
    gy = (sdf[..., :-1, :-1] - sdf[..., 1:, :-1]) / pixel_size  # rows run down, y up
    return gx, gy


def eikonal_loss(gx: Tensor, gy: Tensor) -> Tensor:
    """mean | |grad g| - 1 |."""
    return ((gx.square() + gy.square() + 1e-12).sqrt() - 1).abs().mean()


def band_at(step: int, steps: int, conf: TrainerConf) -> float:
    """Occupancy ramp width in pixels at ``step`` of ``steps``: geometric from start to final."""
    span = conf.band_anneal * steps
    share = 1.0 if span <= 0 else min(1.0, step / span)
    return conf.band_start_px * (conf.band_px / conf.band_start_px) ** share


class FieldStage(L.LightningModule):
    """What both stages share: the field on the grid and Adam with warmup and step decay."""

    def __init__(self, field: Field, grid: ImageGrid, conf: TrainerConf) -> None:
        super().__init__()
        self.field = field
        self.grid = grid
        self.conf = conf

    def grid_sdf(self, times: Tensor) -> tuple[Tensor, Tensor]:
        """SDF frames [T, K, H, W] at ``times`` [T] (rotations) and dg/dt in FOV sides per rotation."""
        c = self.field.on_lattice(self.grid.size)
        shape = (times.shape[0], self.field.n_objects, self.grid.size, self.grid.size)
        rate = self.field.sdf_rate(c, times) / self.grid.extent
        return self.field.sdf(c, times).reshape(shape), rate

    def param_groups(self) -> list[dict]:
        """Adam's parameter groups: the field at trainer.lr."""
        return [{"params": list(self.field.parameters()), "name": "field"}]

    def configure_optimizers(self):
        conf = self.conf
        opt = torch.optim.Adam(self.param_groups(), lr=conf.lr)

        def factor(step: int) -> float:
            return min(1.0, (step + 1) / max(1, conf.warmup_steps)) * conf.lr_decay ** (step // conf.lr_decay_every)

        sched = torch.optim.lr_scheduler.LambdaLR(opt, factor)
        return {"optimizer": opt, "lr_scheduler": {"scheduler": sched, "interval": "step"}}


class InitFit(FieldStage):
    """Algorithm 3: fit the field to SDF frames (L1 in pixels + init_eikonal x Eikonal).

    targets: [T, K, H, W] SDF frames (physical units) at ``times`` [T] in rotations.
    """

    def __init__(self, field: Field, grid: ImageGrid, conf: TrainerConf, loss: LossConf,
                 targets: Tensor, times: Tensor) -> None:
        super().__init__(field, grid, conf)
        self.loss_conf = loss
        self.register_buffer("targets", targets, persistent=False)
        self.register_buffer("times", times, persistent=False)

    def training_step(self, batch: Tensor, batch_idx: int) -> Tensor:
        sdf, _ = self.grid_sdf(self.times[batch])
        misfit = (sdf - self.targets[batch]).abs().mean() / self.grid.pixel_size
        eikonal = eikonal_loss(*spatial_gradient(sdf, self.grid.pixel_size))
        loss = misfit + self.loss_conf.init_eikonal * eikonal
        self.log_dict({"train/sdf": misfit, "train/eikonal": eikonal, "train/loss": loss})
        return loss

    @torch.no_grad()
    def preview(self, n: int) -> Tensor:
        """Target | fitted SDF > 0 at n evenly spaced target times: [2, n, H, W] in [0, 1]."""
        pick = torch.linspace(0, self.times.shape[0] - 1, n).round().long()
        sdf, _ = self.grid_sdf(self.times[pick])
        return torch.stack([(self.targets[pick] > 0).any(1), (sdf > 0).any(1)]).float()


class SinogramFit(FieldStage):
    """Algorithm 4: render the field at each sampled view's time and angle, L1 to the data,
    plus eikonal, tv_space and tv_time terms; the occupancy band narrows as steps go."""

    def __init__(self, field: Field, grid: ImageGrid, conf: TrainerConf, loss: LossConf,
                 views: Views, intensities: Tensor, steps: int) -> None:
        super().__init__(field, grid, conf)
        self.loss_conf = loss
        self.steps = steps
        self.geometry = views.geometry
        self.scale = views.scale
        self.register_buffer("values", views.values, persistent=False)
        self.register_buffer("angles", views.angles, persistent=False)
        self.register_buffer("times", views.times, persistent=False)
        self.log_intensities = torch.nn.Parameter(intensities.log(), requires_grad=conf.fit_intensities)

    @property
    def intensities(self) -> Tensor:
        """a(k) [K]: fitted with the field when ``fit_intensities`` (log-parameterised, stays > 0)."""
        return self.log_intensities.exp()

    def param_groups(self) -> list[dict]:
        groups = super().param_groups()
        if self.conf.fit_intensities:
            groups.append({"params": [self.log_intensities], "lr": self.conf.intensity_lr, "name": "intensities"})
        return groups

    def band(self) -> float:
        """Current ramp width in physical units."""
        return band_at(self.global_step, self.steps, self.conf) * self.grid.pixel_size

    def render(self, sdf: Tensor, views: Tensor, band: float) -> Tensor:
        """Sinogram views [v, n_bins] of SDF frames [v, K, H, W] at the angles of ``views`` [v]."""
        return project_frames(sdf, self.intensities, self.angles[views], self.geometry, self.grid.extent, band,
                              self.conf.mu, self.conf.k_samp)

    def training_step(self, batch: Tensor, batch_idx: int) -> Tensor:
        band = self.band()
        sdf, rate = self.grid_sdf(self.times[batch])
        sinogram = (self.render(sdf, batch, band) - self.values[batch]).abs().mean() / self.scale
        gx, gy = spatial_gradient(sdf, self.grid.pixel_size)
        terms = {"sinogram": sinogram, "eikonal": eikonal_loss(gx, gy),
                 "tv_space": (gx.abs() + gy.abs()).mean(), "tv_time": rate.abs().mean()}
        w = self.loss_conf
        loss = sinogram + w.eikonal * terms["eikonal"] + w.tv_space * terms["tv_space"] + w.tv_time * terms["tv_time"]
        extra = {"train/loss": loss, "train/band_px": band / self.grid.pixel_size}
        extra |= {f"train/intensity_{k}": a for k, a in enumerate(self.intensities.detach())}
        self.log_dict({f"train/{k}": v for k, v in terms.items()} | extra)
        return loss

    @torch.no_grad()
    def sinogram_loss(self, views: Tensor, chunk: int = 64) -> float:
        """Relative L1 misfit over ``views`` [v] with the final band (e.g. held-out views)."""
        band = self.conf.band_px * self.grid.pixel_size
        total = 0.0
        for part in views.to(self.device).split(chunk):
            sdf, _ = self.grid_sdf(self.times[part])
            total += float((self.render(sdf, part, band) - self.values[part]).abs().sum())
        return total / max(1, views.numel() * self.values.shape[1]) / self.scale

    @torch.no_grad()
    def preview(self, n: int) -> Tensor:
        """Intensity frames at n evenly spaced view times: [1, n, H, W]."""
        pick = torch.linspace(0, self.times.shape[0] - 1, n).round().long()
        sdf, _ = self.grid_sdf(self.times[pick])
        return intensity(sdf, self.intensities, self.band(), self.conf.mu)[None]

    @torch.no_grad()
    def residual(self, n: int) -> Tensor:
        """Rendered minus measured sinogram at n evenly spaced views, over the data's max: [n, n_bins]."""
        pick = torch.linspace(0, self.times.shape[0] - 1, n).round().long()
        sdf, _ = self.grid_sdf(self.times[pick])
        return (self.render(sdf, pick, self.band()) - self.values[pick]) / self.values.abs().max().clamp_min(1e-12)


class IndexBatches(IterableDataset):
    """``steps`` random minibatches of ``batch`` indices drawn without replacement from ``pool``."""

    def __init__(self, pool: np.ndarray, batch: int, steps: int, seed: int) -> None:
        self.pool, self.batch, self.steps, self.seed = pool, min(batch, len(pool)), steps, seed

    def __len__(self) -> int:
        return self.steps

    def __iter__(self) -> Iterator[Tensor]:
        rng = np.random.default_rng(self.seed)
        for _ in range(self.steps):
            yield torch.from_numpy(rng.choice(self.pool, size=self.batch, replace=False))


class IndexDataModule(L.LightningDataModule):
    """Serves ``IndexBatches``: the timepoints (views or SDF frames) of each step."""

    def __init__(self, pool: np.ndarray, batch: int, steps: int, seed: int) -> None:
        super().__init__()
        self.batches = IndexBatches(pool, batch, steps, seed)

    def train_dataloader(self) -> DataLoader:
        return DataLoader(self.batches, batch_size=None)


class MinLossStop(Callback):
    """Stop SinogramFit once its sinogram loss falls below ``min_loss`` (Algorithm 4's minLoss)."""

    def __init__(self, min_loss: float) -> None:
        self.min_loss = min_loss

    def on_train_batch_end(self, trainer, pl_module, outputs, batch, batch_idx) -> None:
        value = trainer.callback_metrics.get("train/sinogram")
        if value is not None and float(value) < self.min_loss:
            trainer.should_stop = True


class DivergenceCheck(Callback):
    """Raise DivergenceError on a non-finite loss or one above ``factor`` x the stage's first loss."""

    def __init__(self, stage: str, factor: float) -> None:
        self.stage, self.factor, self.first = stage, factor, None

    def on_train_batch_end(self, trainer, pl_module, outputs, batch, batch_idx) -> None:
        loss = float(outputs["loss"] if isinstance(outputs, dict) else outputs)
        self.first = loss if self.first is None else self.first
        if not math.isfinite(loss) or loss > self.factor * self.first:
            lr = trainer.optimizers[0].param_groups[0]["lr"]
            raise DivergenceError(
                f"stage '{self.stage}' diverged at step {trainer.global_step}: loss {loss:.4g} (first step "
                f"{self.first:.4g}, limit {self.factor:g}x) at learning rate {lr:.3g}; "
                "lower trainer.lr or raise trainer.warmup_steps"
            )


class ImageLog(Callback):
    """Every ``every`` steps (and at the end), frames over time and the sinogram residual to TensorBoard."""

    def __init__(self, stage: str, every: int, n_frames: int = 8, n_views: int = 90) -> None:
        self.stage, self.every, self.n_frames, self.n_views = stage, every, n_frames, n_views

    def on_train_batch_end(self, trainer, pl_module, outputs, batch, batch_idx) -> None:
        if trainer.global_step % self.every == 0 or trainer.global_step >= trainer.max_steps:
            self.log_images(trainer, pl_module)

    def log_images(self, trainer, pl_module) -> None:
        writer = trainer.logger.experiment
        rows = pl_module.preview(self.n_frames)  # [R, n, H, W]: one row per image kind
        strip = torch.cat([torch.cat(list(row), dim=1) for row in rows], dim=0)
        top = float(strip.max().clamp_min(1e-6))
        writer.add_image(f"{self.stage}/frames", (strip / top).clamp(0, 1)[None], trainer.global_step)
        if hasattr(pl_module, "residual"):
            res = pl_module.residual(self.n_views)
            writer.add_image(f"{self.stage}/sinogram_residual", (0.5 + 0.5 * res).clamp(0, 1)[None],
                             trainer.global_step)


def show_progress(conf: TrainerConf) -> bool:
    """The progress bar setting: on when asked, or when stdout is a terminal."""
    return sys.stdout.isatty() if conf.progress_bar is None else bool(conf.progress_bar)


@contextmanager
def quiet_lightning() -> Iterator[None]:
    """Silence Lightning's per-Trainer banners (accelerator, tips, "max_steps reached") and the
    warning about our sized iterable dataset, which has no workers to confuse."""
    log = logging.getLogger("lightning.pytorch")
    level = log.level
    log.setLevel(logging.WARNING)
    try:
        with warnings.catch_warnings():
            warnings.filterwarnings("ignore", message=".*IterableDataset.*__len__.*")
            warnings.filterwarnings("ignore", message=".*LeafSpec.*")
            yield
    finally:
        log.setLevel(level)


def run_stage(module: FieldStage, data: IndexDataModule, steps: int, name: str, conf: TrainerConf,
              log_dir: Path | None, logger: str, extra_callbacks: tuple[Callback, ...] = ()) -> dict:
    """Fit ``module`` for ``steps`` in a fresh Trainer with its own logger version and checkpoint
    folder (``log_dir/tb/<name>``, ``log_dir/checkpoints/<name>``); return steps, losses, wall time."""
    if logger not in LOGGERS:
        raise ValueError(f"logger must be one of {LOGGERS}, got {logger!r}")
    start = time.perf_counter()
    if steps == 0:
        return {"steps": 0, "losses": {}, "wall_time_s": 0.0}
    callbacks: list[Callback] = [DivergenceCheck(name, conf.divergence_factor), *extra_callbacks]
    stage_logger: TensorBoardLogger | CSVLogger | bool = False
    if log_dir is not None and logger == "tensorboard":
        stage_logger = TensorBoardLogger(str(log_dir), name="tb", version=name, default_hp_metric=False)
        callbacks += [LearningRateMonitor("step"), ImageLog(name, conf.image_every_n_steps)]
    elif log_dir is not None and logger == "csv":
        stage_logger = CSVLogger(str(log_dir), name="csv", version=name)
        callbacks.append(LearningRateMonitor("step"))
    with quiet_lightning():
        trainer = L.Trainer(
            accelerator=conf.accelerator, devices=conf.devices, max_steps=steps, max_epochs=1,
            logger=stage_logger, callbacks=callbacks, enable_checkpointing=False,
            enable_progress_bar=show_progress(conf), enable_model_summary=False,
            log_every_n_steps=conf.log_every_n_steps, num_sanity_val_steps=0, limit_val_batches=0,
        )
        trainer.fit(module, datamodule=data)
        if log_dir is not None:
            trainer.save_checkpoint(Path(log_dir) / "checkpoints" / name / "last.ckpt")
    losses = {k.removeprefix("train/"): float(v) for k, v in trainer.callback_metrics.items()
              if k.startswith("train/")}
    return {"steps": int(trainer.global_step), "losses": losses, "wall_time_s": time.perf_counter() - start}
