"""The rigid and affine rungs: a template moved exactly as its poses say, poses with the configured
degrees of freedom, starts from masks, and a tiny reconstruction through the stages."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
import torch
from torch import nn

from nct.acquisition.scanner import ImageGrid
from nct.fields.build import build_field
from nct.fields.conf import ModelConf
from nct.fields.lattice import lattice_points
from nct.fields.moved import POSE_SCALE, SPAN, GridMovedTemplate, MovedTemplate
from nct.fields.series import legendre
from nct.fields.sightings import mask_sightings
from nct.fit.conf import LossConf
from nct.method.reconstruct import reconstruct
from nct.select.conf import SelectionConf
from tests.conftest import INIT, NO_BACKGROUND, OPTIM, TRAINER, moving_disc

PLANE = torch.tensor([[0.7, -0.4], [0.2, 0.9]])  # template k(q) = PLANE[k] . q + OFFSET[k]: bilinear is exact
OFFSET = torch.tensor([0.1, -0.3])


def moved(motion: str = "rigid", family: str = "grid", span: float = 1.0, n_objects: int = 2, **kw) -> MovedTemplate:
    conf = ModelConf(family=family, width=16, depth=2, resolution=16, levels=2, **kw)
    return build_field(conf, n_objects, torch.Generator().manual_seed(0), motion, span)


def plane_template(field: MovedTemplate) -> None:
    """Make every template the plane PLANE[k] . q + OFFSET[k] (q in the template's frame)."""
    k = field.n_objects
    if isinstance(field, GridMovedTemplate):
        with torch.no_grad():
            for level, grid in enumerate(field.template.grids):
                n = grid.shape[-1]
                u = torch.linspace(-2, 2, n)  # the nodes span [-SPAN, SPAN], height index along y
                y, x = torch.meshgrid(u, u, indexing="ij")
                plane = PLANE[:k, 0, None, None] * x + PLANE[:k, 1, None, None] * y + OFFSET[:k, None, None]
                grid.copy_(plane[None] if level == 0 else torch.zeros_like(grid))
    else:
        field.template = nn.Linear(2, k)
        with torch.no_grad():
            field.template.weight.copy_(PLANE[:k])
            field.template.bias.copy_(OFFSET[:k])


def set_poses(field: MovedTemplate, coefficients: dict[int, torch.Tensor]) -> None:
    """Pose channel c's Legendre coefficients [K, N] for each c given."""
    with torch.no_grad():
        for c, values in coefficients.items():
            field.pose[c] = values / POSE_SCALE


@pytest.mark.parametrize("family", ["grid", "siren"])
def test_rigid_field_is_its_template_translated_and_rotated(family):
    field = moved(family=family, pose_terms_per_rotation=2)
    plane_template(field)
    # object 0 moves along a line and turns; object 1 stands still, unturned
    set_poses(field, {0: torch.tensor([[0.1, 0.2], [-0.2, 0.0]]), 1: torch.tensor([[0.05, -0.1], [0.1, 0.0]]),
                      2: torch.tensor([[0.3, 0.5], [0.0, 0.0]])})
    t = torch.tensor([0.0, 0.25, 0.8])
    c = field.on_lattice(16)
    g = field.sdf(c, t)
    s = 2 * t - 1
    centre = torch.stack([torch.stack([0.1 + 0.2 * s, 0.05 - 0.1 * s]), torch.stack([-0.2 + 0 * s, 0.1 + 0 * s])])
    angle = torch.stack([0.3 + 0.5 * s, 0 * s])  # [K, T]
    xy = lattice_points(16)
    for k in range(2):
        for i in range(3):
            d = xy - centre[k, :, i]
            cos, sin = math.cos(angle[k, i]), math.sin(angle[k, i])
            q = torch.stack([cos * d[:, 0] + sin * d[:, 1], -sin * d[:, 0] + cos * d[:, 1]], dim=1)
            torch.testing.assert_close(g[i, k], q @ PLANE[k] + OFFSET[k], atol=1e-5, rtol=1e-5)
    assert g.shape == (3, 2, 256) and field.sdf_rate(c, t).abs().max() == 0


def test_affine_field_scales_and_keeps_a_distance():
    """A uniform scaling by e^a: g = e^a template(q / e^a), so a unit gradient stays one."""
    field = moved(motion="affine", n_objects=1, pose_terms_per_rotation=2)
    plane_template(field)
    set_poses(field, {3: torch.tensor([[0.2, 0.0]]), 4: torch.tensor([[0.2, 0.0]])})
    c = field.on_lattice(16)
    g = field.sdf(c, torch.tensor([0.5]))[0, 0]
    torch.testing.assert_close(g, lattice_points(16) @ PLANE[0] + OFFSET[0] * math.exp(0.2), atol=1e-5, rtol=1e-5)
    set_poses(field, {3: torch.zeros(1, 2), 4: torch.zeros(1, 2), 5: torch.tensor([[0.5, 0.0]])})  # a shear
    g = field.sdf(field.on_lattice(16), torch.tensor([0.5]))[0, 0]
    xy = lattice_points(16)
    q = torch.stack([xy[:, 0] - 0.5 * xy[:, 1], xy[:, 1]], dim=1)
    torch.testing.assert_close(g, q @ PLANE[0] + OFFSET[0], atol=1e-5, rtol=1e-5)


@pytest.mark.parametrize("motion, span, per_rotation, terms", [
    ("rigid", 1.0, 4.0, 4), ("rigid", 3.0, 4.0, 12), ("affine", 3.0, 3.5, 11), ("rigid", 0.2, 4.0, 2)])
def test_poses_have_the_configured_degrees_of_freedom(motion, span, per_rotation, terms):
    field = moved(motion=motion, span=span, pose_terms_per_rotation=per_rotation)
    channels = 3 if motion == "rigid" else 6
    assert field.pose.shape == (channels, 2, terms) and field.describe()["pose_terms"] == terms
    # the time series are polynomials of degree terms - 1 over the scan: they fit one exactly, and no more
    t = torch.linspace(0, span, 40, dtype=torch.float64)
    basis = legendre(2 * t / span - 1, terms)
    for degree, fits in ((terms - 1, True), (terms, False)):
        y = (t / span) ** degree
        residual = y - basis @ torch.linalg.lstsq(basis, y[:, None]).solution[:, 0]
        assert (residual.abs().max() < 1e-8) == fits


def test_poses_start_from_masks():
    """A bar 16 x 4 px turning and moving along a line: its masks' centroids and axes set the start."""
    grid, n = ImageGrid(64), 12
    times = torch.linspace(0, 1, n)
    x, y = np.meshgrid(np.arange(64) - 31.5, 31.5 - np.arange(64))
    masks = np.zeros((n, 1, 64, 64), dtype=bool)
    for i, t in enumerate(times.numpy()):
        cx, cy, a = -10 + 20 * t, 5.0, 0.2 + 1.2 * t
        u = (x - cx) * math.cos(a) + (y - cy) * math.sin(a)
        v = -(x - cx) * math.sin(a) + (y - cy) * math.cos(a)
        masks[i, 0] = (np.abs(u) <= 8) & (np.abs(v) <= 2)
    field = moved(n_objects=1)
    field.start_motion(mask_sightings(masks, times))
    poses = field.poses(torch.tensor([0.0, 0.5, 1.0]))  # [T, 3, K]
    px = 2 / grid.size
    torch.testing.assert_close(poses[:, 0, 0] / px, torch.tensor([-10.0, 0.0, 10.0]), atol=0.3, rtol=0)
    torch.testing.assert_close(poses[:, 1, 0] / px, torch.tensor([5.0, 5.0, 5.0]), atol=0.3, rtol=0)
    torch.testing.assert_close(poses[:, 2, 0], torch.tensor([0.2, 0.8, 1.4]), atol=0.05, rtol=0)
    # a free centre's template spans the whole image; a held one's the bar (half-diagonal 8.2 px) with room to spare
    assert field.extent[0] == SPAN
    field.start_motion(replace(mask_sightings(masks, times), held=True))
    assert 8.2 * px < field.extent[0] / 1.5 and field.extent[0] < SPAN / 2
    # a disc gives no axis: its angle starts at zero
    disc = np.hypot(x, y)[None, None] <= 10
    assert mask_sightings(np.repeat(disc, n, axis=0), times).angles.abs().max() == 0


def test_held_centres_are_not_fitted():
    """Centres read off the views' first moments (``held``) get no gradient; the angle does."""
    times = torch.linspace(0, 1, 6)
    masks = np.zeros((6, 1, 32, 32), dtype=bool)
    masks[:, :, 10:20, 12:16] = True
    field = moved(n_objects=1)
    field.start_motion(replace(mask_sightings(masks, times), held=True))
    field.poses(times).square().sum().backward()
    assert field.pose.grad[:2].abs().max() == 0 and field.pose.grad[2].abs().max() > 0


def test_a_held_siren_template_is_rendered_over_its_reach_only():
    """A held object's template lattice has ``resolution`` points per field of view over its reach (fewer points
    a step), a free one's ``resolution`` a side; a reloaded field renders the same lattice and the same g."""
    times = torch.linspace(0, 1, 6)
    masks = np.zeros((6, 1, 32, 32), dtype=bool)
    masks[:, :, 10:20, 12:16] = True
    field = moved(family="siren", n_objects=1)
    assert field.side == 16
    field.start_motion(replace(mask_sightings(masks, times), held=True))
    assert field.side == math.ceil(16 * float(field.extent[0])) and 2 <= field.side < 16
    reloaded = moved(family="siren", n_objects=1)
    reloaded.load_state_dict(field.state_dict())
    assert reloaded.side == field.side
    torch.testing.assert_close(reloaded.sdf(reloaded.on_lattice(8), times), field.sdf(field.on_lattice(8), times))


def test_an_affine_field_relaxed_from_a_rigid_one_draws_the_same_g():
    """``relax``: the rigid field's template, poses, reach, intensities and background, the affine channels at zero."""
    rigid, affine = moved("rigid", family="siren"), moved("affine", family="siren")
    set_poses(rigid, {0: torch.tensor([[0.1, 0.05, 0.0, 0.0], [-0.2, 0.0, 0.02, 0.0]]), 2: torch.full((2, 4), 0.3)})
    rigid.extent.copy_(torch.tensor([0.6, 2.0]))
    rigid.held[:2] = True
    rigid.set_intensities(torch.tensor([0.5, -2.0]))
    rigid.set_background(torch.rand(8, 8))
    affine.relax(rigid.state_dict())
    times = torch.linspace(0, 1, 5)
    torch.testing.assert_close(affine.sdf(affine.on_lattice(12), times), rigid.sdf(rigid.on_lattice(12), times))
    assert affine.side == rigid.side and affine.held.tolist() == [True, True, False, False, False, False]
    assert torch.equal(affine.intensities, rigid.intensities) and torch.equal(affine.background, rigid.background)
    assert not affine.pose[3:].any()


@pytest.mark.parametrize("family", ["grid", "siren"])
def test_tiny_rigid_reconstruction_runs_and_moves_the_disc(family):
    """The disc of the tiny acquisition orbits 60 deg/rotation: the rigid fit's centres follow it."""
    grid = ImageGrid(32)
    sino, times = moving_disc(grid)
    model = ModelConf(family=family, width=16, depth=2, resolution=32, levels=2)
    result = reconstruct(sino, grid, times, model, LossConf(), TRAINER, 0, log_dir=None, logger="none",
                         motion=SelectionConf(rungs=["rigid"]), optim=OPTIM, init=INIT, background=NO_BACKGROUND)
    assert result.frames.shape == (6, 32, 32) and result.model["motion"] == "rigid"
    assert result.model["pose_terms"] == 4 and result.model["n_terms"] == 0
    # the frames' centroids travel the orbit (radius 0.15 FOV, 60 deg over the rotation)
    inside = result.sdf[:, 0] > 0
    u = (np.arange(32) + 0.5) / 32 - 0.5
    cx = (inside * u[None, None, :]).sum(axis=(1, 2)) / inside.sum(axis=(1, 2))
    cy = (inside * -u[None, :, None]).sum(axis=(1, 2)) / inside.sum(axis=(1, 2))
    truth = sino.truth.frames > 0.5 * sino.truth.frames.max()
    tx = (truth * u[None, None, :]).sum(axis=(1, 2)) / truth.sum(axis=(1, 2))
    ty = (truth * -u[None, :, None]).sum(axis=(1, 2)) / truth.sum(axis=(1, 2))
    assert np.hypot(cx - tx, cy - ty).max() < 2 / 32
    assert np.hypot(cx[-1] - cx[0], cy[-1] - cy[0]) > 1.5 / 32  # it moves: the truth's ends are 4.1 px apart


def test_an_affine_candidate_starts_from_its_rigid_ones_initfit():
    """Rigid and affine from one start: one InitFit, the affine fit starting where the rigid one did."""
    grid = ImageGrid(32)
    sino, times = moving_disc(grid)
    model = ModelConf(family="siren", width=16, depth=2, resolution=32)
    result = reconstruct(sino, grid, times, model, LossConf(), TRAINER, 0, log_dir=None, logger="none",
                         motion=SelectionConf(rungs=["rigid", "affine"]), optim=OPTIM, init=INIT,
                         background=NO_BACKGROUND)
    stages = result.stages
    assert stages["rigid_init"]["steps"] == OPTIM.init_steps
    assert stages["affine_init"] == {"steps": 0, "wall_time_s": 0.0, "misfit": stages["rigid_init"]["misfit"],
                                     "from": "rigid_init"}
    assert stages["affine_fit"]["misfit_start"] == pytest.approx(stages["rigid_fit"]["misfit_start"], rel=1e-5)


@pytest.mark.parametrize("held", [False, True])
def test_a_siren_template_rendered_where_the_points_reach_is_the_whole_lattices(held):
    """The SIREN rendered on the window its points reach gives the values and gradients of the whole lattice's,
    points beyond the lattice (held at its border) included."""
    field = moved(family="siren", n_objects=2)
    if held:
        field.extent.copy_(torch.tensor([0.6, 0.9]))
        field.read_buffers()
    q = (torch.rand(2, 300, 2, generator=torch.Generator().manual_seed(1)) * 0.8 + 0.1).requires_grad_()
    q2 = q.detach().clone().requires_grad_()
    side = field.side
    image = field.template(lattice_points(side) * SPAN).T.reshape(2, 1, side, side)
    where = q2 * q2.new_tensor([1.0, -1.0]) / field.extent[:, None, None]
    whole = torch.nn.functional.grid_sample(image, where[:, None], mode="bilinear", padding_mode="border",
                                            align_corners=False)[:, 0, 0]
    window = field.lookup(field.on_lattice(8), q)
    assert torch.allclose(window, whole, atol=1e-6)
    weights = torch.randn_like(whole)
    grads = [torch.autograd.grad((out * weights).sum(), [x, *field.template.parameters()])
             for out, x in ((window, q), (whole, q2))]
    for a, b in zip(*grads):
        assert torch.allclose(a, b, atol=1e-5, rtol=1e-4)
