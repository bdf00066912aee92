"""Projector along any `Geometry`'s rays (differentiable, torch): the forward model of every fit
(filtered backprojection: ``fbp.py``).

Rays as in ``geometry.py``; x right, y up. Sinogram values are line integrals in physical units.
"""

from __future__ import annotations

import math
from functools import lru_cache

import torch
import torch.nn.functional as F
from torch import Tensor, nn

from nct.acquisition.geometry import Geometry, ParallelGeometry


class Projector(nn.Module):
    """Line integrals of square images along the rays of a `Geometry`, by bilinear sampling (``grid_sample``).

    Holds the fixed ray samples: ``bin_samples`` rays per bin (averaged, spread evenly over the
    bin's width in detector coordinate) and samples every ``ray_step`` (default: one pixel) along
    each ray across the whole field of view, centred on the ray's closest approach to the axis.
    """

    def __init__(
        self,
        geometry: Geometry,
        size: int,
        extent: float,
        ray_step: float | None = None,
        bin_samples: int = 1,
    ) -> None:
        super().__init__()
        _check_sampling(size, extent, ray_step, bin_samples)
        half = extent / 2
        geometry.check_source_outside(half * math.sqrt(2), "the image's half-diagonal")
        self.n_bins = geometry.n_bins
        # Rays in grid_sample's units (half the image side is 1), computed in the images' dtype.
        self.unit_geometry = geometry.scaled(1 / half)
        self.bin_samples = bin_samples
        self.step = float(ray_step) if ray_step is not None else extent / size
        sub = (torch.arange(bin_samples, dtype=torch.float64) + 0.5) / bin_samples - 0.5
        centres = torch.from_numpy(geometry.bin_positions)
        self.register_buffer("u_norm", (centres[:, None] + sub[None, :] * geometry.bin_spacing).reshape(-1) / half)
        # Rays cross at most the square's diagonal, plus the half pixel that bilinear sampling reaches.
        reach = half * math.sqrt(2) + extent / size
        n_t = math.ceil(2 * reach / self.step) + 1
        t = (torch.arange(n_t, dtype=torch.float64) - (n_t - 1) / 2) * self.step
        self.register_buffer("t_norm", t / half)
        self.register_buffer("down", torch.tensor([1.0, -1.0], dtype=torch.float64))  # y up -> rows down

    def sampling_grid(self, angles: Tensor) -> Tensor:
        """Where the rays of the views at ``angles`` [B] sample an image, in grid_sample's coordinates
        (y down the rows), in the angles' dtype: [B, n_bins * bin_samples, n_t, 2]."""
        point, direction = self.unit_geometry.rays(angles, self.u_norm.to(angles))
        down = self.down.to(angles)
        point, direction = point * down, direction * down
        t = self.t_norm.to(angles)
        # Each coordinate's p + t v written into its slice of one contiguous grid: half the time of one
        # broadcast over the last axis of 2, the same values; grid_sample's backward on a grid of other
        # strides takes another path and rounds differently.
        grid = point.new_empty(*point.shape[:2], t.shape[0], 2)
        for axis in (0, 1):
            torch.addcmul(point[..., axis, None], t, direction[..., axis, None], out=grid[..., axis])
        return grid

    def along(self, images: Tensor, grid: Tensor) -> Tensor:
        """Project image b along the rays of ``grid`` b ([B,H,W], a `sampling_grid` [B, ...]) or one image
        along all ([H,W]): [B, n_bins]."""
        n_views, n_rays, n_t = grid.shape[:3]
        if images.ndim == 2:
            samples = F.grid_sample(images[None, None], grid.reshape(1, n_views * n_rays, n_t, 2), align_corners=False)
        else:
            samples = F.grid_sample(images[:, None], grid, align_corners=False)
        sums = samples.reshape(n_views, self.n_bins, self.bin_samples, n_t).sum(dim=-1)
        return sums.mean(dim=-1) * self.step

    def forward(self, images: Tensor, angles: Tensor) -> Tensor:
        """Project image b at angle b ([B,H,W], [B]) or one image at every angle ([H,W], [B]): [B, n_bins]."""
        if images.ndim not in (2, 3) or images.shape[-1] != images.shape[-2]:
            raise ValueError(f"images must be [B,H,W] or [H,W] with H == W, got shape {tuple(images.shape)}")
        if angles.ndim != 1 or (images.ndim == 3 and angles.shape[0] != images.shape[0]):
            raise ValueError(
                f"angles must be [B] matching images [B,H,W], got {tuple(angles.shape)} for {tuple(images.shape)}"
            )
        return self.along(images, self.sampling_grid(angles.to(images)))


def _check_sampling(size: int, extent: float, ray_step: float | None, bin_samples: int) -> None:
    checks = {
        "size (image pixels a side) must be >= 2": size >= 2,
        "extent must be > 0": extent > 0,
        "ray_step must be None or > 0": ray_step is None or ray_step > 0,
        "bin_samples must be >= 1": bin_samples >= 1,
    }
    failed = [rule for rule, ok in checks.items() if not ok]
    if failed:
        raise ValueError(
            f"projector: {'; '.join(failed)} (got size={size}, extent={extent}, ray_step={ray_step},"
            f" bin_samples={bin_samples})"
        )


@lru_cache(maxsize=16)
def projector_for(geometry: Geometry, size: int, extent: float, ray_step: float | None, bin_samples: int,
                  device: torch.device, dtype: torch.dtype) -> Projector:
    """One projector per setting, its ray buffers already on the images' device and in their
    dtype: no host-device copy in a fitting step."""
    return Projector(geometry, size, extent, ray_step, bin_samples).to(device=device, dtype=dtype)


def project(
    images: Tensor,
    angles: Tensor,
    geometry: Geometry,
    extent: float,
    ray_step: float | None = None,
    bin_samples: int = 1,
) -> Tensor:
    """Differentiable line integrals along ``geometry``'s rays: images [B,H,W] (or one [H,W]), angles [B] rad
    -> [B, n_bins].

    Each image b is projected at its own angle b (one frame per view of a moving scene); images
    cover ``extent`` a side. ``ray_step`` / ``bin_samples``: see ``Projector``.
    """
    size = int(images.shape[-1])
    return projector_for(geometry, size, float(extent), ray_step, int(bin_samples), images.device,
                      images.dtype)(images, angles)


def forward_project(
    images: Tensor,
    angles: Tensor,
    extent: float,
    n_bins: int,
    bin_spacing: float,
    ray_step: float | None = None,
    bin_samples: int = 1,
) -> Tensor:
    """`project` in parallel beam with a centred detector of ``n_bins`` bins ``bin_spacing`` apart."""
    try:
        geometry = ParallelGeometry(int(n_bins), float(bin_spacing))
    except ValueError as err:
        raise ValueError(f"projector: {err}") from None
    return project(images, angles, geometry, extent, ray_step, bin_samples)
