"""The optimisation stages of NeuralCT: InitFit (Algorithm 3) and SinogramFit (Algorithm 4).

Both stages evaluate the field's networks once per step on the whole grid and form the SDF at
every sampled time through the Fourier basis; spatial derivatives (Eikonal, TV) are finite
differences on the grid. The modules only optimise; running them in a Trainer is ``trainer.py``;
data, export and metrics live elsewhere.
"""

from __future__ import annotations

from collections.abc import Callable

import lightning as L
import numpy as np
import torch
from torch import Tensor

from nct.acquisition.scanner import ImageGrid
from nct.fields.base import Coefficients, SpaceTimeField
from nct.fields.lattice import upsample
from nct.fit.conf import LossConf, OptimConf, RenderConf
from nct.fit.problem import HeldoutHistory, Views
from nct.fit.render import project_frames
from nct.physics.data_term import misfit


def spatial_gradient(sdf: Tensor, pixel_size: float) -> tuple[Tensor, Tensor]:
    """Forward differences dg/dx, dg/dy on the grid: [..., H, W] -> two [..., H-1, W-1]."""
    gx = (sdf[..., :-1, 1:] - sdf[..., :-1, :-1]) / pixel_size
    gy = (sdf[..., :-1, :-1] - sdf[..., 1:, :-1]) / pixel_size  # rows run down, y up
    return gx, gy


def eikonal_loss(gx: Tensor, gy: Tensor) -> Tensor:
    """mean | |grad g| - 1 |."""
    return ((gx.square() + gy.square() + 1e-12).sqrt() - 1).abs().mean()


def total_variation(image: Tensor) -> Tensor:
    """mean(|db/dx| + |db/dy|) of an image [H, W] per pixel (anisotropic TV; the static background's term)."""
    return (image[:, 1:] - image[:, :-1]).abs().mean() + (image[1:, :] - image[:-1, :]).abs().mean()


def balanced_l1(sdf: Tensor, targets: Tensor) -> Tensor:
    """Mean |sdf - targets| with the inside (targets > 0) and the outside weighted equally, per
    object: a small object's few inside pixels would otherwise lose to the background, and a
    field negative everywhere (the object lost, with no gradient to bring it back) would fit well.
    sdf: [T, K, H, W] (or one frame [1, K, H, W] against every target), targets: [T, K, H, W]."""
    err = (sdf - targets).abs()
    inside = (targets > 0).to(err.dtype)
    dims = (0, 2, 3)
    parts = [(err * w).sum(dims) / w.sum(dims).clamp_min(1.0) for w in (inside, 1 - inside)]
    return 0.5 * (parts[0] + parts[1]).mean()


def band_at(step: int, steps: int, conf: RenderConf) -> float:
    """Occupancy ramp width in pixels at ``step`` of ``steps``: geometric from start to final."""
    span = conf.band_anneal * steps
    share = 1.0 if span <= 0 else min(1.0, step / span)
    return conf.band_start_px * (conf.band_px / conf.band_start_px) ** share


def weighted(sinogram: Tensor, regularisers: dict[str, tuple[float, Callable[[], Tensor]]], logged: bool
             ) -> tuple[dict[str, Tensor], Tensor]:
    """The terms and the loss of a step: the ``sinogram`` term plus each regulariser's weight times its term, in
    order. A term of weight 0 adds nothing, its gradient included, so it stays out of the graph and is computed,
    without gradient, only on a step whose values are ``logged`` (the defaults' tv_space and tv_time: a seventh of
    the default run's tournament, benchmarks/results/speed)."""
    terms, loss = {"sinogram": sinogram}, sinogram
    for name, (weight, term) in regularisers.items():
        if weight:
            terms[name] = term()
            loss = loss + weight * terms[name]
        elif logged:
            with torch.no_grad():
                terms[name] = term()
    return terms, loss


def logging_step(trainer: L.Trainer, step: int) -> bool:
    """Whether 0-based ``step`` is one the Trainer's logger writes (every log_every_n_steps-th,
    counting from 1) or the last: the steps on which a value is worth reading back."""
    return (step + 1) % trainer.log_every_n_steps == 0 or step + 1 >= trainer.max_steps


class FieldStage(L.LightningModule):
    """What both stages share: the field on the grid and Adam with warmup and step decay."""

    def __init__(self, field: SpaceTimeField, grid: ImageGrid, optim: OptimConf, lattice: int | None = None) -> None:
        super().__init__()
        self.field = field
        self.grid = grid
        self.optim = optim
        self.lattice = min(lattice or grid.size, grid.size)
        self.heldout_history: HeldoutHistory = []

    def grid_sdf(self, times: Tensor, c: Coefficients | None = None) -> Tensor:
        """SDF frames [T, K, H, W] at ``times`` [T] (rotations): the field evaluated on ``lattice``^2
        points (from ``c``, its coefficients there, when the caller holds them) and upsampled
        bilinearly to the grid."""
        n = self.lattice
        c = self.field.on_lattice(n) if c is None else c
        frames = self.field.sdf(c, times).reshape(times.shape[0], self.field.n_objects, n, n)
        return upsample(frames, self.grid.size) if n < self.grid.size else frames

    def drawn_sdf(self, times: Tensor, c: Coefficients | None = None) -> Tensor:
        """The SDF frames a step draws at ``times`` [T]: `grid_sdf`'s [T, K, H, W], or for a still field its one
        frame [1, K, H, W], which serves every time (a static model's step then draws, upsamples and regularises
        one frame, not one per view)."""
        return self.grid_sdf(times[:1] if self.field.still else times, c)

    def log_due(self, values: dict[str, Tensor]) -> None:
        """Log ``values`` on the steps the Trainer writes (its count starts at 1) and the last step
        only: Lightning's bookkeeping of logged values costs about as much as a coarse step."""
        if logging_step(self.trainer, self.global_step):
            self.log_dict(values)

    def param_groups(self) -> list[dict]:
        """Adam's parameter groups: the field's shape at optim.lr."""
        return [{"params": self.field.shape_parameters(), "name": "field"}]

    def configure_optimizers(self):
        conf = self.optim
        # foreach: one call per group for every tensor, not a Python loop over them: the same values to the bit
        # (tests/fit/test_stages.py), without the loop's 4 dtype copies per tensor a step (CPU's default).
        opt = torch.optim.Adam(self.param_groups(), lr=conf.lr, foreach=True)

        def factor(step: int) -> float:
            return min(1.0, (step + 1) / max(1, conf.warmup_steps)) * conf.lr_decay ** (step // conf.lr_decay_every)

        sched = torch.optim.lr_scheduler.LambdaLR(opt, factor)
        return {"optimizer": opt, "lr_scheduler": {"scheduler": sched, "interval": "step"}}


class InitFit(FieldStage):
    """Algorithm 3: fit the field to SDF frames (balanced L1 in pixels + init_eikonal x Eikonal).

    targets: [T, K, H, W] SDF frames (physical units) at ``times`` [T] in rotations.
    """

    def __init__(self, field: SpaceTimeField, grid: ImageGrid, optim: OptimConf, loss: LossConf,
                 targets: Tensor, times: Tensor, lattice: int | None = None) -> None:
        super().__init__(field, grid, optim, lattice)
        self.loss_conf = loss
        self.register_buffer("targets", targets, persistent=False)
        self.register_buffer("times", times, persistent=False)

    def param_groups(self) -> list[dict]:
        """The field's ``frame_parameters`` at optim.lr (a moved template's poses are the sinogram's to fit)."""
        return [{"params": self.field.frame_parameters(), "name": "field"}]

    def training_step(self, batch: Tensor, batch_idx: int) -> Tensor:
        sdf = self.drawn_sdf(self.times[batch])
        sdf_misfit = balanced_l1(sdf, self.targets[batch]) / self.grid.pixel_size
        eikonal = eikonal_loss(*spatial_gradient(sdf, self.grid.pixel_size))
        loss = sdf_misfit + self.loss_conf.init_eikonal * eikonal
        self.log_due({"train/sdf": sdf_misfit, "train/eikonal": eikonal, "train/loss": loss})
        return loss


class SinogramFit(FieldStage):
    """Algorithm 4: render the field at each sampled view's time and angle, the data term (L1 or Poisson),
    plus eikonal, tv_space and tv_time terms (and tv_background with a static background); the
    occupancy band narrows as steps go."""

    def __init__(self, field: SpaceTimeField, grid: ImageGrid, optim: OptimConf, render: RenderConf, loss: LossConf,
                 views: Views, steps: int, lattice: int | None = None) -> None:
        super().__init__(field, grid, optim, lattice)
        self.render_conf = render
        self.loss_conf = loss
        self.steps = steps
        self.geometry = views.geometry
        self.scale = views.scale
        self.register_buffer("values", views.values, persistent=False)
        self.register_buffer("angles", views.angles, persistent=False)
        self.register_buffer("times", views.times, persistent=False)
        self.register_buffer("sigma", views.sigma, persistent=False)

    @property
    def intensities(self) -> Tensor:
        """a(k) [K], the field's: fitted with its shape when ``optim.fit_intensities``."""
        return self.field.intensities

    def param_groups(self) -> list[dict]:
        groups = super().param_groups()
        if self.optim.fit_intensities:
            groups.append({"params": [self.field.log_intensities], "lr": self.optim.intensity_lr,
                           "name": "intensities"})
        if self.field.background is not None:
            groups.append({"params": [self.field.background], "lr": self.optim.background_lr, "name": "background"})
        return groups

    def band(self) -> float:
        """Current ramp width in physical units."""
        return band_at(self.global_step, self.steps, self.render_conf) * self.grid.pixel_size

    def render(self, sdf: Tensor, views: Tensor, band: float) -> Tensor:
        """Sinogram views [v, n_bins] of SDF frames [v, K, H, W] (or one frame [1, K, H, W] for all) at the angles
        of ``views`` [v]."""
        return project_frames(sdf, self.intensities, self.angles[views], self.geometry, self.grid.extent, band,
                              self.render_conf.mu, self.render_conf.k_samp, self.field.background)

    def training_step(self, batch: Tensor, batch_idx: int) -> dict[str, Tensor]:
        band = self.band()
        times = self.times[batch]
        c = self.field.on_lattice(self.lattice)
        sdf = self.drawn_sdf(times, c)
        sinogram = misfit(self.render(sdf, batch, band), self.values[batch],
                          None if self.sigma is None else self.sigma[batch], self.scale)
        gx, gy = spatial_gradient(sdf, self.grid.pixel_size)
        w = self.loss_conf
        regularisers = {"eikonal": (w.eikonal, lambda: eikonal_loss(gx, gy)),
                        "tv_space": (w.tv_space, lambda: (gx.abs() + gy.abs()).mean()),
                        # |dg/dt| [T, K, P], in field-of-view sides per rotation
                        "tv_time": (w.tv_time, lambda: (self.field.sdf_rate(c, times) / self.grid.extent).abs().mean())}
        if self.field.background is not None:
            regularisers["tv_background"] = (w.tv_background, lambda: total_variation(self.field.background))
        terms, loss = weighted(sinogram, regularisers, logging_step(self.trainer, self.global_step))
        extra = {"train/loss": loss, "train/band_px": band / self.grid.pixel_size}
        extra |= {f"train/intensity_{k}": a for k, a in enumerate(self.intensities.detach())}
        self.log_due({f"train/{k}": v for k, v in terms.items()} | extra)
        return {"loss": loss, "sinogram": sinogram.detach()}

    @torch.no_grad()
    def view_misfits(self, views: Tensor) -> Tensor:
        """|rendered - measured| summed over each view's bins, with the final band, over the data's
        scale: [v] for ``views`` [v]."""
        band = self.render_conf.band_px * self.grid.pixel_size
        sdf = self.drawn_sdf(self.times[views])
        return (self.render(sdf, views, band) - self.values[views]).abs().sum(-1) / self.scale

    def misfit_sum(self, views: Tensor) -> Tensor:
        """Sum of ``view_misfits`` over ``views`` [v]."""
        return self.view_misfits(views).sum()

    def view_losses(self, views: Tensor, chunk: int = 64) -> np.ndarray:
        """Relative L1 misfit of each of ``views`` [v] with the final band (e.g. held-out views): [v] float64."""
        parts = [self.view_misfits(part).double().cpu().numpy() for part in views.to(self.device).split(chunk)]
        return np.concatenate(parts) / self.values.shape[1] if parts else np.zeros(0)

    def on_validation_epoch_start(self) -> None:
        self._held_sum, self._held_count = 0.0, 0

    def validation_step(self, batch: Tensor, batch_idx: int) -> None:
        """Held-out views ``batch`` [v]: their misfit adds to ``val/heldout_loss``, the truth-free score."""
        self._held_sum += float(self.misfit_sum(batch))
        self._held_count += batch.numel() * self.values.shape[1]

    def on_validation_epoch_end(self) -> None:
        held = self._held_sum / max(1, self._held_count)
        self.heldout_history.append((int(self.global_step), held))
        self.log("val/heldout_loss", held)
