"""The rigid and affine rungs of the motion ladder: a template shape moved smoothly in time.

g_k(x, t) = sqrt(det A_k(t)) template_k(A_k(t)^-1 (x - c_k(t))), A = R(theta) (rigid) or
R(theta) [[e^a, h], [0, e^b]] (affine: log-scales a, b and a shear h; a beating ellipse is a
scaling). The factor keeps g a distance under a uniform scaling (the Eikonal term holds there).

Each pose parameter (c_x, c_y, theta and a, b, h) is a series of Legendre polynomials over the
scan, a few per rotation (``model.pose_terms_per_rotation``), not a network. Polynomials assume
nothing periodic over the scan (a Fourier series over the span ties c(0) to c(end); its cosine form
converges slowly on motion that is not: 2-7 px off a circle's orbit at 4 terms per rotation where
Legendre is 0.01-1 px), and Legendre polynomials are orthogonal on the span, so Adam's steps on
their coefficients are well conditioned. Fewer terms leave less room for the motion along each
view's rays that the data cannot see, which turns with the gantry at one cycle per rotation.
"""

from __future__ import annotations

from dataclasses import dataclass

import torch
import torch.nn.functional as F
from torch import Tensor, nn

from nct.fields.base import MultiGrid, Siren, SpaceTimeField
from nct.fields.conf import ModelConf
from nct.fields.lattice import lattice_points, reach_side, reached_window, window_grid
from nct.fields.series import legendre, legendre_fit, on_scan, series_terms
from nct.fields.sightings import Sightings

SPAN = 2.0  # a template covers at most [-SPAN, SPAN]^2 about its centre: the whole image for any centre in it
POSE = {"rigid": ("x", "y", "angle"), "affine": ("x", "y", "angle", "log_scale_x", "log_scale_y", "shear")}
POSE_SCALE = 10.0  # the poses' series are stored over this: Adam steps them 10x the template's (~0.6 px at lr 1e-3)


@dataclass(frozen=True)
class Lattice:
    """What ``MovedTemplate.sdf`` needs of a step: the P points [P, 2] it draws g at."""

    points: Tensor


class MovedTemplate(SpaceTimeField):
    """A template per object moved by smooth poses (module docstring), the template a SIREN
    rendered once per step on a side x side lattice and looked up bilinearly at the moved points (a
    SIREN at every moved point costs ~6x more per step); so g is one function of x whatever the
    lattice. Template k covers [-SPAN, SPAN]^2 about its centre; one whose centre is held
    (``Sightings``) covers its object's reach only (``start_motion``; circle at 100 deg/rotation,
    rigid: 0.998, 0.931 at SPAN). Beyond it the lookup holds its border (outside the object, so g < 0
    there). A free centre keeps SPAN: at the finer pitch the vessel over a background drifted 12 px
    along the rays (0.24 against 0.87). The lattice holds ``model.resolution`` points per field of
    view over what the templates cover, at most ``resolution`` a side (``side``): a held circle's disc
    gets 71 a side (a 1-px pitch at 128 px): a rigid step 29 ms on one thread, the free field's 26-31,
    where 128 a side took 57 at the same Dice (benchmarks/results/rungs).

    dg/dt (``sdf_rate``) is zero: the poses' smoothness is in their basis, and the tv_time term on
    a moving template would penalise the motion itself (|dg/dt| is the boundary's speed), not a
    change of shape, of which the template has none.
    """

    def __init__(self, conf: ModelConf, motion: str, n_objects: int, span: float) -> None:
        super().__init__(n_objects)
        self.motion = motion
        self.n_basis = series_terms(conf, span)
        self.template = self.make_template(conf, n_objects)
        self.resolution = conf.resolution
        self.pose = nn.Parameter(torch.zeros(len(POSE[motion]), n_objects, self.n_basis))
        self.register_buffer("span", torch.tensor(float(span)))
        self.register_buffer("extent", torch.full((n_objects,), SPAN))
        self.register_buffer("held", torch.zeros(len(POSE[motion]), dtype=torch.bool))  # pose series not fitted
        self.read_buffers()

    def read_buffers(self) -> None:
        """Mirror the templates' reach as their lattice's side (``SpaceTimeField.read_buffers``)."""
        self._side = reach_side(self.resolution, float(self.extent.max()))

    @property
    def side(self) -> int:
        """Points a side of the lattice the templates are rendered on: ``model.resolution`` per field of view
        over the share of it they cover (``extent``), at most ``resolution``; from the buffer, so a reloaded
        field has its own."""
        return self._side

    @staticmethod
    def make_template(conf: ModelConf, n_objects: int) -> nn.Module:
        """The templates, one channel per object."""
        return Siren(2, conf.width, conf.depth, n_objects, conf.omega0)

    def on_lattice(self, size: int) -> Lattice:
        """The pixel centres of a size x size image."""
        return Lattice(lattice_points(size, self.span.device))

    def lookup(self, c: Lattice, q: Tensor) -> Tensor:
        """Template k at its own points q[k] [K, Q, 2] (template frame): [K, Q]. The SIREN is rendered on the window
        of its lattice that the points reach (the bilinear lookup reads no other point, so g is the same): a free
        centre's lattice covers twice the image a side, of which a step reaches 26-62 % (benchmarks/results/rungs)."""
        where = q * q.new_tensor([1.0, -1.0]) / self.extent[:, None, None]  # the rendered rows run down, y up
        rows, cols = reached_window(where, self.side)
        points = lattice_points(self.side, self.span.device).reshape(self.side, self.side, 2)[rows, cols]
        image = self.template(points.reshape(-1, 2) * SPAN).T.reshape(self.n_objects, 1, *points.shape[:2])
        return F.grid_sample(image, window_grid(where, self.side, rows, cols)[:, None], mode="bilinear",
                             padding_mode="border", align_corners=False)[:, 0, 0]

    def basis(self, t: Tensor) -> Tensor:
        """The Legendre basis over the scan at times t [T] (rotations): [T, n_basis]."""
        return legendre(on_scan(t, self.span), self.n_basis)

    def poses(self, t: Tensor) -> Tensor:
        """Every pose parameter (``POSE``) at times t [T]: [T, C, K]."""
        pose = torch.where(self.held[:, None, None], self.pose.detach(), self.pose)
        return torch.einsum("tn,ckn->tck", self.basis(t), pose) * POSE_SCALE

    def sdf(self, c: Lattice, t: Tensor) -> Tensor:
        """g at times t [T] at the lattice's points: [T, K, P]."""
        pose = self.poses(t).permute(1, 2, 0)[..., None]  # [C, K, T, 1]
        dx = c.points[:, 0] - pose[0]  # [K, T, P]
        dy = c.points[:, 1] - pose[1]
        cos, sin = pose[2].cos(), pose[2].sin()
        u, v = cos * dx + sin * dy, cos * dy - sin * dx  # R(-theta)(x - c)
        scale = None
        if self.motion == "affine":  # [[e^a, h], [0, e^b]]^-1 (u, v)
            a, b, h = pose[3], pose[4], pose[5]
            u, v = (u - h * (-b).exp() * v) * (-a).exp(), v * (-b).exp()
            scale = ((a + b) / 2).exp()
        k, n_t, n_p = u.shape
        values = self.lookup(c, torch.stack([u, v], dim=-1).reshape(k, n_t * n_p, 2)).reshape(k, n_t, n_p)
        return (values if scale is None else values * scale).transpose(0, 1)

    def sdf_rate(self, c: Lattice, t: Tensor) -> Tensor:
        """Zero, [T, K, P] (class docstring)."""
        return c.points.new_zeros(t.shape[0], self.n_objects, c.points.shape[0])

    def frame_parameters(self) -> list[nn.Parameter]:
        """The templates' only: InitFit's SDF frames (from FBP) are averages over half a rotation of
        views, no instant's poses; the poses start from ``start_motion`` and are fitted to the sinogram."""
        return list(self.template.parameters())

    @torch.no_grad()
    def start_motion(self, seen: Sightings) -> None:
        """Set the centre and angle series to their least-squares fit to ``seen`` and each template's
        half-width to its object's reach, holding the centres where ``seen`` says so; an affine map
        starts as a rotation."""
        targets = torch.cat([seen.centres.permute(2, 1, 0), seen.angles.T[None]]).to(self.pose)  # [3, K, F]
        fit = legendre_fit(on_scan(seen.times, self.span), targets.reshape(-1, targets.shape[-1]).T, self.n_basis)
        self.pose.zero_()
        self.pose[:3] = fit.T.reshape(3, self.n_objects, self.n_basis) / POSE_SCALE
        self.held[:2] = seen.held
        if seen.held:  # a free centre keeps SPAN: at a finer pitch it drifted along the rays (docstring)
            self.extent.copy_(seen.cover().clamp(max=SPAN))
        self.read_buffers()

    @torch.no_grad()
    def relax(self, rigid: dict) -> None:
        """Become, as an affine field, the rigid one whose state is ``rigid``: its template, reach, intensities and
        background, its pose series in the rotation's channels and the scalings' and shear's at zero."""
        state = dict(rigid)
        pose, held = torch.zeros_like(self.pose), torch.zeros_like(self.held)
        pose[:3], held[:3] = state.pop("pose"), state.pop("held")
        if "background" in state:
            self.set_background(state["background"])
        self.load_state_dict(state | {"pose": pose, "held": held})

    def describe(self) -> dict:
        """Capacity summary: the rung, parameter count, pose terms."""
        return {
            "n_params": sum(p.numel() for p in self.shape_parameters()),
            "n_terms": 0,
            "pose_terms": self.n_basis,
            "static": False,
            "omega_abs_max": 0.0,
        }


class GridMovedTemplate(MovedTemplate):
    """The same with the templates on explicit grids (``MultiGrid``, the free grid field's cell size),
    looked up directly at the moved points."""

    @staticmethod
    def make_template(conf: ModelConf, n_objects: int) -> nn.Module:
        return MultiGrid(n_objects, round(conf.resolution * SPAN), conf.levels)

    def lookup(self, c: Lattice, q: Tensor) -> Tensor:
        return self.template.each(q / self.extent[:, None, None])


def moved_template(conf: ModelConf, motion: str, n_objects: int, span: float) -> MovedTemplate:
    """The ``motion`` (rigid or affine) field of ``conf.family`` for ``n_objects`` objects on a scan of
    ``span`` rotations."""
    return {"siren": MovedTemplate, "grid": GridMovedTemplate}[conf.family](conf, motion, n_objects, span)
