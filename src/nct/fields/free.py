"""The static rung and the paper's free field g = g_E(x) + g_V(x, t) (Sec. IV-A), in both families.

Time enters the free field only through a Fourier basis, so the spatial parts see x alone: evaluate them once on
the grid and form g(., t) for any number of times by a product with the basis (see ``Field.sdf``).
"""

from __future__ import annotations

import math
from dataclasses import replace

import torch
import torch.nn.functional as F
from torch import Tensor, nn

from nct.fields.base import Coefficients, MultiGrid, Siren, SpaceTimeField
from nct.fields.conf import ModelConf
from nct.fields.lattice import interpolation_on_pixels, lattice_points, pixel_centres, reach_side
from nct.fields.series import legendre, legendre_fit, on_scan, series_terms
from nct.fields.sightings import Sightings


class Field(SpaceTimeField):
    """g(x, t) = g_E(x) + (1/M) sum_i A_i(x) sin(2 pi w_i t) + B_i(x) cos(2 pi w_i t), K outputs
    (M = 0: the static rung).

    x: points scaled to [-1, 1] (x right, y up); t: time in gantry rotations. The frequencies
    w_i ~ N(0, f_max) are drawn once from ``generator``.

    A lone object whose centre is held (``Sightings.held``: its mass centroid's path read off the
    views) is carried along that path: g(x, t) = h(x - d(t), t), h the sum above, d(t) = c(t) minus
    its mean m, a Legendre series (``model.pose_terms_per_rotation`` per rotation of the ``span``,
    as the rigid rung's poses) fitted to the start's centres. h holds the shape in the object's own
    frame; its freedom to slide each chord along the rays where no view sees it goes with the
    translation the first moments fix. h is rendered on a lattice over the object's reach about m
    (``Sightings.cover``; its border held beyond), ``model.carry_resolution`` pixels per field of view
    (``side``), and moved by a bilinear lookup, two interpolation matrices per time: deterministic
    products, and g one function of x whatever lattice asks for it. The static rung is not carried.
    Where the object's axis is held too (``Sightings.turned``: an elongated rigid shape's, orientation.py),
    h turns with it: g(x, t) = h(R(-phi(t)) (x - c(t)), t), phi the axis about its mean (a Legendre series
    as d), looked up by bilinear sampling (a turn is not separable). Among several objects, one part
    turning about a still centre m (``Sightings.turned``: object k, its axis read off the views beside
    still ones) turns likewise, uncarried: g_k(x, t) = h_k(m + R(-phi(t)) (x - m), t) on the image's lattice.
    """

    def __init__(self, conf: ModelConf, n_objects: int, generator: torch.Generator, span: float = 1.0) -> None:
        super().__init__(n_objects)
        self.n_terms = conf.n_terms
        self.static = self.spatial(conf, n_objects, temporal=False)
        self.temporal = self.spatial(conf, 2 * conf.n_terms * n_objects, temporal=True) if conf.n_terms else None
        self.register_buffer("omega", torch.randn(conf.n_terms, generator=generator) * conf.f_max)
        self.carry_resolution = conf.carry_resolution
        self.n_carry = series_terms(conf, span)
        self.register_buffer("span", torch.tensor(float(span)))
        self.register_buffer("carry", torch.zeros(2, self.n_carry))  # d(t)'s series, image units
        self.register_buffer("centre", torch.zeros(2))  # m: the carried path's mean, or a turning part's centre
        self.register_buffer("extent", torch.tensor(1.0))  # h's lattice covers m +- this
        self.register_buffer("carried", torch.tensor(False))
        self.register_buffer("turn", torch.zeros(self.n_carry))  # phi(t)'s series, rad
        self.register_buffer("turned", torch.tensor(False))
        self.register_buffer("turned_object", torch.tensor(0))  # k, the object that turns with phi
        self.read_buffers()

    def read_buffers(self) -> None:
        """Mirror the motion buffers (``SpaceTimeField.read_buffers``)."""
        self._carried, self._turned = bool(self.carried), bool(self.turned)
        self._turned_object = int(self.turned_object)
        self._side = reach_side(self.carry_resolution, float(self.extent))

    @property
    def side(self) -> int:
        """Pixels a side of h's lattice: ``model.carry_resolution`` per field of view over the share
        ``extent`` of it that the lattice covers, at most ``carry_resolution`` (a carried field renders
        no more points than an uncarried one); from the buffer, so a reloaded field has its own."""
        return self._side

    @torch.no_grad()
    def start_motion(self, seen: Sightings) -> None:
        """Carry a lone object's field along ``seen``'s centres where they are held, and turn the object
        whose axis they hold (class docstring)."""
        if self.temporal is None:
            return
        s = on_scan(seen.times, self.span)
        if seen.held and self.n_objects == 1:
            centres = seen.centres[:, 0].to(self.carry)  # [F, 2]
            self.centre.copy_(centres.mean(dim=0))
            self.carry.copy_(legendre_fit(s, centres - self.centre, self.n_carry).T)
            self.extent.copy_(seen.cover()[0])
            self.carried.fill_(True)
        elif seen.turned is not None:
            self.centre.copy_(seen.centres[:, seen.turned].mean(dim=0))
        if seen.turned is not None:
            angles = seen.angles[:, seen.turned, None].to(self.turn)  # [F, 1]
            self.turn.copy_(legendre_fit(s, angles - angles.mean(), self.n_carry)[:, 0])
            self.turned.fill_(True)
            self.turned_object.fill_(seen.turned)
        self.read_buffers()

    @property
    def still(self) -> bool:
        """Without temporal terms g is g_E alone, at every time (``sdf``)."""
        return self.temporal is None

    @staticmethod
    def spatial(conf: ModelConf, n_out: int, temporal: bool) -> nn.Module:
        """The module mapping points [P, 2] to ``n_out`` values [P, n_out]: a SIREN here."""
        if temporal:
            return Siren(2, conf.temporal_width, conf.temporal_depth, n_out, conf.omega0)
        return Siren(2, conf.width, conf.depth, n_out, conf.omega0)

    def coefficients(self, xy: Tensor) -> Coefficients:
        """Evaluate both spatial parts once at points ``xy`` [P, 2]; time enters later by ``sdf``."""
        return self._split(self.static(xy).T, None if self.temporal is None else self.temporal(xy).T)

    def on_lattice(self, size: int) -> Coefficients:
        """What ``sdf`` needs for g at the pixel centres of a size x size image (rows down, P = size**2):
        the coefficients there, or on h's own lattice where the field is carried."""
        if not self._carried:
            return self.rendered(size)
        return replace(self.rendered(self.side, self.centre, self.extent), carry_to=size)

    def rendered(self, size: int, centre: Tensor | None = None, extent: Tensor | None = None) -> Coefficients:
        """``coefficients`` at the pixel centres of a size x size lattice over ``centre`` +- ``extent``
        (None: the image)."""
        xy = lattice_points(size, self.omega.device)
        return self.coefficients(xy if centre is None else centre + extent * xy)

    def _split(self, static: Tensor, temporal: Tensor | None) -> Coefficients:
        """Coefficients from static [K, P] and temporal [2MK, P] values."""
        if temporal is None:
            return Coefficients(static, None)
        return Coefficients(static, temporal.reshape(2 * self.n_terms, self.n_objects, -1))

    def basis(self, t: Tensor) -> Tensor:
        """The Fourier basis with the 1/M factor: t [T] -> [T, 2M] (sines, then cosines)."""
        phase = 2 * math.pi * t[:, None] * self.omega[None, :]
        return torch.cat([torch.sin(phase), torch.cos(phase)], dim=1) / self.n_terms

    def basis_rate(self, t: Tensor) -> Tensor:
        """d basis / dt: t [T] -> [T, 2M]."""
        rate = 2 * math.pi * self.omega[None, :]
        phase = rate * t[:, None]
        return torch.cat([rate * torch.cos(phase), -rate * torch.sin(phase)], dim=1) / self.n_terms

    def sdf(self, c: Coefficients, t: Tensor) -> Tensor:
        """g at times t [T] from coefficients at P points: [T, K, P]."""
        static = c.static.expand(t.shape[0], -1, -1)
        if c.temporal is None:
            return static
        return self.carry_along(static + torch.einsum("tm,mkp->tkp", self.basis(t), c.temporal), t, c.carry_to)

    def sdf_rate(self, c: Coefficients, t: Tensor) -> Tensor:
        """dg/dt (per rotation) at times t [T]: [T, K, P]; zero for a static model. A carried field's
        is its shape's rate in its own frame, carried: the tv_time term penalises a change of shape,
        not the motion the path holds."""
        if c.temporal is None:
            return c.static.new_zeros(t.shape[0], *c.static.shape)
        return self.carry_along(torch.einsum("tm,mkp->tkp", self.basis_rate(t), c.temporal), t, c.carry_to)

    def carry_along(self, values: Tensor, t: Tensor, size: int | None) -> Tensor:
        """h ``values`` [T, 1, S^2] on its own lattice moved along the carried path and looked up at the
        pixel centres of a size x size image: h(x - d(t)) [T, 1, size^2] (bilinear, h's border held
        beyond it); where size is None (not carried), ``values`` [T, K, P] with a turning part's
        channel turned (class docstring)."""
        if size is None:
            return self._turned_part(values, t) if self._turned else values
        series = legendre(on_scan(t, self.span), self.n_carry)
        shift = series @ self.carry.T + self.centre  # d(t) + m, [T, 2]
        u = pixel_centres(size, values.device).to(values)
        side = math.isqrt(values.shape[-1])
        if self._turned:
            h = values.reshape(t.shape[0], 1, side, side)
            return self._turned_along(h, shift, series @ self.turn, u, torch.zeros_like(self.centre))
        rows = interpolation_on_pixels((u + shift[:, 1:]) / self.extent, side)  # rows run down, y up
        cols = interpolation_on_pixels((u - shift[:, :1]) / self.extent, side)
        h = values.reshape(t.shape[0], side, side)
        return (rows @ h @ cols.transpose(-1, -2)).reshape(t.shape[0], 1, size * size)

    def _turned_part(self, values: Tensor, t: Tensor) -> Tensor:
        """``values`` [T, K, P] on the image's lattice with object k's channel looked up at
        m + R(-phi(t)) (x - m): [T, K, P]."""
        k, side = self._turned_object, math.isqrt(values.shape[-1])
        phi = legendre(on_scan(t, self.span), self.n_carry) @ self.turn
        h = values[:, k:k + 1].reshape(t.shape[0], 1, side, side)
        u = pixel_centres(side, values.device).to(values)
        looked = self._turned_along(h, self.centre.expand(t.shape[0], 2), phi, u, self.centre)
        return torch.cat([values[:, :k], looked, values[:, k + 1:]], dim=1)

    def _turned_along(self, h: Tensor, shift: Tensor, phi: Tensor, u: Tensor, offset: Tensor) -> Tensor:
        """h [T, 1, S, S] over ``extent`` looked up at ``offset`` + R(-phi) (x - shift) for x the pixel
        centres ``u`` [n] of an n x n image, shift [T, 2], phi [T], offset [2]: [T, 1, n^2] (bilinear, h's
        border held, as ``carry_along``)."""
        dx = u[None, None, :] - shift[:, :1, None]  # [T, 1, n]: columns
        dy = -u[None, :, None] - shift[:, 1:, None]  # [T, n, 1]: rows run down, y up
        cos, sin = phi.cos()[:, None, None], phi.sin()[:, None, None]
        qx = (offset[0] + cos * dx + sin * dy) / self.extent
        qy = (offset[1] + cos * dy - sin * dx) / self.extent
        where = torch.stack([qx, -qy], dim=-1)  # grid_sample's y runs down the rows
        looked = F.grid_sample(h, where, mode="bilinear", padding_mode="border", align_corners=False)
        return looked.reshape(h.shape[0], 1, -1)

    def describe(self) -> dict:
        """Capacity summary: family, sizes, parameter count, frequencies."""
        return {
            "n_params": sum(p.numel() for p in self.shape_parameters()),
            "n_terms": self.n_terms,
            "static": self.temporal is None,
            "omega_abs_max": float(self.omega.abs().max()) if self.n_terms else 0.0,
            "carried": self._carried,
            "turned": self._turned,
            "turned_object": self._turned_object if self._turned else None,
        }


class GridField(Field):
    """The same g(x, t) with explicit grids for g_E and for the Fourier coefficients of g_V."""

    @staticmethod
    def spatial(conf: ModelConf, n_out: int, temporal: bool) -> nn.Module:
        return MultiGrid(n_out, conf.temporal_resolution if temporal else conf.resolution, conf.levels)

    def rendered(self, size: int, centre: Tensor | None = None, extent: Tensor | None = None) -> Coefficients:
        return self._split(self.static.on_lattice(size, centre, extent),
                           None if self.temporal is None else self.temporal.on_lattice(size, centre, extent))
