"""Bilinear lookups between square lattices over [-1, 1] (pixel centres), as matrices where they separate.

A lookup on a lattice splits into one matrix for the rows and one for the columns; its backward is
then a product too, far cheaper on a CPU than ``grid_sample``'s. The fields render on a coarse lattice
and move or upsample what they render through these.
"""

from __future__ import annotations

import math
from functools import lru_cache

import torch
from torch import Tensor


def reach_side(per_view: int, extent: float) -> int:
    """Points a side of a lattice with ``per_view`` points per field of view (which spans [-1, 1]) over
    +- ``extent`` about a centre: at most ``per_view`` (a lattice over an object's reach renders no more
    points than one over the image), at least 2."""
    return max(2, math.ceil(per_view * min(extent, 1.0) - 1e-6))


@lru_cache(maxsize=16)
def pixel_centres(size: int, device: torch.device | None = None) -> Tensor:
    """Centres of ``size`` pixels spanning [-1, 1], increasing: [size] float32. Cached per device
    (a carried field asks for them every step; a copy to a GPU waits for its queue): do not modify."""
    return ((2 * torch.arange(size, dtype=torch.float32) + 1) / size - 1).to(device)


@lru_cache(maxsize=8)
def lattice_points(size: int, device: torch.device | None = None) -> Tensor:
    """Pixel centres of a size x size image spanning [-1, 1]: x right, y up, row-major [size**2, 2].
    Cached per device (evaluated every step, no copy): do not modify the result."""
    u = pixel_centres(size)
    y, x = torch.meshgrid(-u, u, indexing="ij")
    return torch.stack([x.ravel(), y.ravel()], dim=1).to(device)


def interpolation_matrix(u: Tensor, cells: int) -> Tensor:
    """Linear interpolation from ``cells`` nodes spanning [-1, 1] to coordinates u [n]: [n, cells]."""
    return _linear_weights((u + 1) / 2 * (cells - 1), cells)


def interpolation_on_pixels(u: Tensor, cells: int) -> Tensor:
    """Linear interpolation from the pixel centres of a ``cells``-pixel axis spanning [-1, 1] to
    coordinates u [..., n], constant beyond the outer centres: [..., n, cells]."""
    return _linear_weights((u + 1) / 2 * cells - 0.5, cells)


def _linear_weights(pos: Tensor, cells: int) -> Tensor:
    """Linear interpolation from ``cells`` nodes at 0, 1, ... to positions ``pos`` [..., n] in node
    units, constant beyond the ends: [..., n, cells]."""
    if cells == 1:
        return pos.new_ones(*pos.shape, 1)
    pos = pos.clamp(0, cells - 1)
    left = pos.floor().long().clamp(max=cells - 2)[..., None]
    weight = pos[..., None] - left
    return pos.new_zeros(*pos.shape, cells).scatter_(-1, left, 1 - weight).scatter_(-1, left + 1, weight)


@lru_cache(maxsize=8)
def upsampling_matrix(size: int, lattice: int, device: torch.device | None = None,
                      dtype: torch.dtype = torch.float32) -> Tensor:
    """Bilinear resampling, one axis, from the pixel centres of a ``lattice``-pixel image to those
    of a ``size``-pixel image of the same extent: [size, lattice] (F.interpolate's
    align_corners=False, as a matrix: its backward is a product too, far cheaper on a CPU).
    Cached per device and dtype: do not modify."""
    return interpolation_on_pixels(pixel_centres(size), lattice).to(device, dtype)


def upsample(images: Tensor, size: int) -> Tensor:
    """Bilinear upsampling of square images [..., n, n] to [..., size, size] (see upsampling_matrix)."""
    m = upsampling_matrix(size, images.shape[-1], images.device, images.dtype)
    return m @ images @ m.T


@lru_cache(maxsize=32)
def lattice_interpolation(size: int, cells: int, device: torch.device | None = None) -> tuple[Tensor, Tensor]:
    """Bilinear lookup of a cells x cells grid at the pixel centres of a size x size image, as
    matrices for image rows (y runs down) and columns: two [size, cells]. Cached per device: do not modify."""
    u = pixel_centres(size)
    return interpolation_matrix(-u, cells).to(device), interpolation_matrix(u, cells).to(device)


def reached_window(where: Tensor, side: int) -> tuple[slice, slice]:
    """The rows and columns of a ``side`` x ``side`` image that ``grid_sample`` (bilinear, border padding,
    align_corners=False) touches at ``where`` [..., 2] (x along the columns, y down the rows, [-1, 1]): a lookup
    in that window alone (`window_grid`) gives the same values and gradients. Reads ``where`` back (a GPU waits)."""
    index = (((where.detach().reshape(-1, 2) + 1) * side - 1) / 2).nan_to_num(0.0).clamp(0, side - 1)
    (c0, r0), (c1, r1) = index.amin(0).floor().long().tolist(), index.amax(0).floor().long().tolist()
    return slice(r0, min(r1 + 2, side)), slice(c0, min(c1 + 2, side))


def window_grid(where: Tensor, side: int, rows: slice, cols: slice) -> Tensor:
    """``where`` [..., 2] on the whole ``side`` x ``side`` image as coordinates on its window ``rows`` x ``cols``
    (grid_sample's, align_corners=False): [..., 2]."""
    low = where.new_tensor([cols.start, rows.start])
    n = where.new_tensor([cols.stop - cols.start, rows.stop - rows.start])
    return ((where + 1) * side - 2 * low) / n - 1
