"""What every field of the motion ladder is built on: the interface the stages use (``SpaceTimeField``),
and the two families of spatial parts, SIRENs (the paper's) and explicit multi-resolution grids
(``MultiGrid``: bilinear lookups instead of a network, several times cheaper per step)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import torch
import torch.nn.functional as F
from torch import Tensor, nn

from nct.fields.lattice import (
    interpolation_matrix,
    lattice_interpolation,
    pixel_centres,
)
from nct.fields.sightings import Sightings

HIDDEN_OMEGA = 30.0  # SIREN's frequency for hidden layers (Sitzmann et al.); its init compensates


class Siren(nn.Module):
    """Sine-activated MLP (Sitzmann et al. 2020): [P, in] -> [P, out]; the last layer is linear."""

    def __init__(self, n_in: int, width: int, depth: int, n_out: int, omega0: float) -> None:
        super().__init__()
        sizes = [n_in] + [width] * depth
        self.hidden = nn.ModuleList(nn.Linear(a, b) for a, b in zip(sizes[:-1], sizes[1:]))
        self.out = nn.Linear(width, n_out)
        self.omegas = [omega0] + [HIDDEN_OMEGA] * (depth - 1)
        with torch.no_grad():
            for i, layer in enumerate(self.hidden):
                bound = 1 / layer.in_features if i == 0 else math.sqrt(6 / layer.in_features) / HIDDEN_OMEGA
                layer.weight.uniform_(-bound, bound)
            bound = math.sqrt(6 / width) / HIDDEN_OMEGA
            self.out.weight.uniform_(-bound, bound)

    def forward(self, x: Tensor) -> Tensor:
        for omega, layer in zip(self.omegas, self.hidden):
            x = torch.sin(omega * layer(x))
        return self.out(x)


@dataclass
class Coefficients:
    """The free field's networks evaluated at P points: static [K, P], temporal [2M, K, P] (None if M = 0).
    ``carry_to``: where the field is carried, the side of the lattice g is looked up on (the
    coefficients then lie on the field's own lattice); None: g is at the coefficients' points."""

    static: Tensor
    temporal: Tensor | None
    carry_to: int | None = None


class SpaceTimeField(nn.Module):
    """What the stages use of a field of K objects (every rung of the motion ladder):
    ``on_lattice(size)`` evaluates what does not depend on time once per step and returns it as an
    opaque value c; ``sdf(c, t)`` [T, K, P] and ``sdf_rate(c, t)`` [T, K, P] give g and dg/dt (per
    rotation) at the lattice's P points at times t [T] (rotations). The field also owns each
    object's intensity a(k) (its magnitude log-parameterised, so its sign stays the start's: < 0 only
    for an object darker than the one it nests in, segment.nest; 1 until ``set_intensities``) and
    the static background image b [H, W] under the objects where there is one (None until
    ``set_background``; background.py), so one checkpoint holds everything that renders the image."""

    def __init__(self, n_objects: int) -> None:
        super().__init__()
        self.n_objects = n_objects
        self.log_intensities = nn.Parameter(torch.zeros(n_objects))
        self.register_buffer("signs", torch.ones(n_objects))
        self.register_parameter("background", None)
        self.register_load_state_dict_post_hook(_reread_buffers)

    def read_buffers(self) -> None:
        """Mirror the buffers that choose what a step computes as Python values (none here): reading a
        buffer on a GPU waits for every queued kernel, and a step asks for them each time. Called again
        whenever a state is loaded, so a reloaded field has its own."""

    @property
    def still(self) -> bool:
        """Whether g is the same at every time (the static rung): a step then draws one frame for all its views."""
        return False

    @property
    def intensities(self) -> Tensor:
        """a(k) [K]."""
        return self.signs * self.log_intensities.exp()

    @torch.no_grad()
    def set_intensities(self, values: Tensor) -> None:
        """Start a(k) at ``values`` [K] (nonzero), e.g. Algorithm 1's estimate; their signs stay."""
        values = values.to(self.log_intensities)
        self.signs.copy_(torch.where(values < 0, -1.0, 1.0))
        self.log_intensities.copy_(values.abs().log())

    @torch.no_grad()
    def set_background(self, image: Tensor) -> None:
        """Hold (or restart) the static background b at ``image`` [H, W]."""
        if self.background is None or self.background.shape != image.shape:
            self.background = nn.Parameter(image.detach().clone().to(self.log_intensities))
        else:
            self.background.copy_(image)

    def shape_parameters(self) -> list[nn.Parameter]:
        """The parameters of g (all but a(k) and the background)."""
        return [p for p in self.parameters() if p is not self.log_intensities and p is not self.background]

    def frame_parameters(self) -> list[nn.Parameter]:
        """The parameters InitFit fits to SDF frames: all of g's here."""
        return self.shape_parameters()

    def start_motion(self, seen: Sightings) -> None:
        """Start the field's motion where the objects were ``seen`` (fields/moved.py); the static field has
        none, the free one carries a lone object along its held path (``Field``)."""


def _reread_buffers(field: SpaceTimeField, _keys) -> None:
    """After a field's state is loaded, mirror its buffers again (``SpaceTimeField.read_buffers``)."""
    field.read_buffers()


class MultiGrid(nn.Module):
    """Sum of ``levels`` grids of ``n_out`` channels, res, res/2, ... cells per side, looked up
    bilinearly: [P, 2] in [-1, 1] -> [P, n_out]. Starts at zero; coarse levels move whole regions
    per step, fine ones the detail, so a fit goes coarse to fine by itself."""

    def __init__(self, n_out: int, resolution: int, levels: int) -> None:
        super().__init__()
        self.grids = nn.ParameterList(
            nn.Parameter(torch.zeros(1, n_out, resolution >> i, resolution >> i)) for i in range(levels)
        )

    def forward(self, xy: Tensor) -> Tensor:
        where = xy.view(1, 1, -1, 2)
        total = sum(F.grid_sample(g, where, mode="bilinear", padding_mode="border", align_corners=True)
                    for g in self.grids)
        return total[0, :, 0].T

    def each(self, xy: Tensor) -> Tensor:
        """Channel k looked up at its own points: xy [n_out, Q, 2] -> [n_out, Q]."""
        where = xy[:, None]
        total = sum(F.grid_sample(g.transpose(0, 1), where, mode="bilinear", padding_mode="border",
                                  align_corners=True) for g in self.grids)
        return total[:, 0, 0]

    def on_lattice(self, size: int, centre: Tensor | None = None, extent: Tensor | None = None) -> Tensor:
        """``forward`` at the pixel centres of a size x size lattice over ``centre`` [2] +- ``extent``
        (None: the image), [n_out, size**2]: bilinear lookups on a lattice are separable, two small
        matrix products per level (much cheaper than ``grid_sample``'s backward on a CPU)."""
        total = 0
        for g in self.grids:
            if centre is None:
                rows, cols = lattice_interpolation(size, g.shape[-1], g.device)
            else:
                u = pixel_centres(size, g.device)
                rows = interpolation_matrix(centre[1] - extent * u, g.shape[-1])
                cols = interpolation_matrix(centre[0] + extent * u, g.shape[-1])
            total = total + rows @ g[0] @ cols.T
        return total.reshape(total.shape[0], -1)
