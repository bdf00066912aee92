"""Neural SDF fields: shapes, the static family, the Fourier basis in time, a lone object carried along
its path, config validation."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
import torch

from nct.fields.build import build_field
from nct.fields.conf import ModelConf
from nct.fields.free import GridField
from nct.fields.lattice import upsample
from nct.fields.sightings import Sightings

XY = torch.rand(50, 2, generator=torch.Generator().manual_seed(0)) * 2 - 1
SMALL = dict(width=16, depth=2, temporal_width=8, temporal_depth=2)


def field(seed: int = 0, **kw):
    return build_field(ModelConf(**(SMALL | kw)), n_objects=2, generator=torch.Generator().manual_seed(seed))


def test_shapes():
    f = field(n_terms=5)
    c = f.coefficients(XY)
    assert c.static.shape == (2, 50) and c.temporal.shape == (10, 2, 50)
    t = torch.tensor([0.0, 0.3, 0.7])
    assert f.sdf(c, t).shape == (3, 2, 50) and f.sdf_rate(c, t).shape == (3, 2, 50)


def test_sdf_is_static_plus_fourier_series():
    """g(x, t) = g_E(x) + (1/M) sum_i A_i(x) sin(2 pi w_i t) + B_i(x) cos(2 pi w_i t)."""
    f = field(n_terms=4)
    c = f.coefficients(XY)
    t = 0.37
    by_hand = c.static.clone()
    for i, w in enumerate(f.omega):
        by_hand += (c.temporal[i] * math.sin(2 * math.pi * w * t) + c.temporal[4 + i] * math.cos(2 * math.pi * w * t)) / 4
    torch.testing.assert_close(f.sdf(c, torch.tensor([t]))[0], by_hand, atol=1e-5, rtol=1e-5)


def test_time_derivative_matches_finite_difference():
    f = field(n_terms=6, f_max=0.8)
    c = f.coefficients(XY)
    t, h = torch.tensor([0.4], dtype=torch.float64), 1e-4
    f = f.double()
    c = f.coefficients(XY.double())
    numeric = (f.sdf(c, t + h) - f.sdf(c, t - h)) / (2 * h)
    torch.testing.assert_close(f.sdf_rate(c, t), numeric, atol=1e-6, rtol=1e-5)


def test_static_model_has_no_temporal_terms():
    f = field(n_terms=0)
    c = f.coefficients(XY)
    assert f.temporal is None and c.temporal is None and f.describe()["static"]
    assert not any("temporal" in name for name, _ in f.named_parameters())
    g = f.sdf(c, torch.tensor([0.0, 5.0]))
    torch.testing.assert_close(g[0], g[1])
    assert f.sdf_rate(c, torch.tensor([1.0])).abs().max() == 0


def sightings(held: bool, px: float = 1.0, reach: float = 0.6) -> Sightings:
    """An object seen at t = 0, 0.5, 1 moving 4 px right and 2 px down (of a 32-px image) over the
    scan, times ``px``; at ``reach`` 0.6 its shape's lattice spans the image's width."""
    times = torch.tensor([0.0, 0.5, 1.0])
    centres = torch.stack([times * 8 / 32, -times * 4 / 32], dim=-1)[:, None, :] * px
    return Sightings(times, centres, torch.zeros(3, 1), torch.full((1,), reach), held)


def lone(family: str = "siren", n_terms: int = 3):
    """A one-object free field carried on a 32^2 lattice, grids given a shape (they start at zero)."""
    torch.manual_seed(0)  # the SIRENs' weights
    f = build_field(ModelConf(**SMALL, n_terms=n_terms, family=family, carry_resolution=32), n_objects=1,
                    generator=torch.Generator().manual_seed(0))
    if family == "grid":
        torch.nn.init.normal_(f.static.grids[0], generator=torch.Generator().manual_seed(1))
    return f


def test_one_part_turns_about_its_centre_and_the_others_stay():
    """Object 1 of two seen at the pixel centre m = (5, -3)/32 with its axis at -90, 0, +90 deg: at t = 1
    its channel is the unturned one looked up at m + R(-90 deg)(x - m) (pixel centres onto pixel
    centres), object 0's is unchanged, and the field is not carried."""
    f = field(n_terms=3)
    t, size = torch.tensor([1.0]), 32
    still = f.sdf(f.on_lattice(size), t)[0].detach()
    centres = torch.tensor([[0.0, 0.0], [5 / 32, -3 / 32]]).expand(3, 2, 2)
    angles = torch.tensor([[0.0, -1.0], [0.0, 0.0], [0.0, 1.0]]) * math.pi / 2
    seen = Sightings(torch.tensor([0.0, 0.5, 1.0]), centres, angles, torch.full((2,), 0.6), turned=1)
    f.start_motion(seen)
    turned = f.sdf(f.on_lattice(size), t)[0].detach()
    assert f.describe()["turned_object"] == 1 and not f.describe()["carried"]
    torch.testing.assert_close(turned[0], still[0])
    # pixel (row i, column j) lies at x = (2j + 1)/32 - 1, y = 1 - (2i + 1)/32; m at column 18, row 17
    i, j = np.meshgrid(np.arange(size), np.arange(size), indexing="ij")
    source_j, source_i = 18 - (i - 17), 17 + (j - 18)  # R(-90 deg) (dx, dy) = (dy, -dx), rows run down
    inside = (source_i >= 0) & (source_i < size) & (source_j >= 0) & (source_j < size)
    expected = still[1].reshape(size, size)[source_i[inside], source_j[inside]]
    torch.testing.assert_close(turned[1].reshape(size, size)[inside], expected, atol=1e-5, rtol=1e-4)


@pytest.mark.parametrize("family", ["siren", "grid"])
def test_a_held_object_is_carried_along_its_path(family):
    """g(x - d(t), t), d the centres' path about its mean: at t = 1 (d = 2 px right, 1 down) the carried
    lattice is the uncarried one moved by exactly that (bilinear at whole pixels), away from the borders."""
    f = lone(family)
    t = torch.tensor([1.0])
    still = f.sdf(f.on_lattice(32), t).reshape(32, 32).detach()
    f.start_motion(sightings(held=True))
    carried = f.sdf(f.on_lattice(32), t).reshape(32, 32).detach()
    assert f.describe()["carried"] and "carry" in f.state_dict()
    torch.testing.assert_close(carried[4:-4, 4:-4], still[3:-5, 2:-6], atol=1e-5, rtol=1e-4)


def test_a_turned_object_turns_with_its_axis():
    """Held still at the centre with its axis at -90, 0 and +90 deg at t = 0, 0.5, 1: at t = 1 the
    carried lattice is the uncarried one turned a quarter counter-clockwise (pixel centres onto pixel
    centres), and the state dict holds the turn."""
    f = lone()
    t = torch.tensor([1.0])
    still = f.sdf(f.on_lattice(32), t).reshape(32, 32).detach()
    seen = replace(sightings(held=True, px=0.0, reach=0.6), angles=torch.tensor([[-1.0], [0.0], [1.0]]) * math.pi / 2,
                   turned=0)
    f.start_motion(seen)
    turned = f.sdf(f.on_lattice(32), t).reshape(32, 32).detach()
    assert f.describe()["turned"] and "turn" in f.state_dict()
    torch.testing.assert_close(turned, torch.rot90(still, 1, (0, 1)), atol=1e-5, rtol=1e-4)


def test_a_field_loaded_from_a_turned_carried_ones_state_renders_the_same():
    """The motion the buffers hold comes with the state (its Python mirrors are read again on loading):
    a fresh field given a turned, carried field's state renders its g; given a fresh one's, it stops."""
    f, fresh = lone(), lone()
    plain = {k: v.clone() for k, v in fresh.state_dict().items()}
    f.start_motion(replace(sightings(held=True, px=0.3, reach=0.3),
                           angles=torch.tensor([[-1.0], [0.0], [1.0]]) * math.pi / 4, turned=0))
    t = torch.tensor([0.3, 1.0])
    fresh.load_state_dict(f.state_dict())
    assert fresh.describe()["carried"] and fresh.describe()["turned"] and fresh.side == f.side < 32
    torch.testing.assert_close(fresh.sdf(fresh.on_lattice(32), t), f.sdf(f.on_lattice(32), t), atol=0, rtol=0)
    f.load_state_dict(plain)
    assert not f.describe()["carried"] and not f.describe()["turned"]
    torch.testing.assert_close(f.sdf(f.on_lattice(32), t), lone().sdf(lone().on_lattice(32), t), atol=0, rtol=0)


@pytest.mark.parametrize("family", ["siren", "grid"])
def test_a_carried_field_is_one_function_of_x_whatever_the_lattice(family):
    """Every third pixel centre of a 96-px lattice is one of the 32-px lattice's: the same g and dg/dt
    there, with the shape's lattice over a part of the image and shifts of a fraction of a pixel."""
    f = lone(family)
    f.start_motion(sightings(held=True, px=0.3, reach=0.3))
    t = torch.tensor([0.2, 0.9])
    coarse, fine = f.on_lattice(32), f.on_lattice(96)
    for g in (f.sdf, f.sdf_rate):
        torch.testing.assert_close(g(fine, t).reshape(2, 96, 96)[..., 1::3, 1::3],
                                   g(coarse, t).reshape(2, 32, 32), atol=1e-5, rtol=1e-4)


def test_a_carried_fit_is_deterministic():
    """Gradients through the carried lookup (interpolation matrices, not grid_sample) repeat exactly."""
    grads = []
    for _ in range(2):
        f = lone()
        f.start_motion(sightings(held=True, px=0.3, reach=0.3))
        f.sdf(f.on_lattice(24), torch.linspace(0, 1, 5)).square().sum().backward()
        grads.append(torch.cat([p.grad.ravel() for p in f.shape_parameters()]))
    torch.testing.assert_close(grads[0], grads[1], rtol=0, atol=0)


def test_a_carried_shape_has_the_lattice_density_over_its_reach_and_keeps_it_on_reload():
    """32 pixels per field of view over a reach 1.5 x 0.3 + 0.1 = 0.55 of it: 18 a side, and no more
    than 32 over a reach wider than the field; a field loaded from the state dict renders the same
    lattice and the same g."""
    wide = lone()
    wide.start_motion(sightings(held=True, px=0.3, reach=0.8))
    assert wide.side == 32
    f = lone()
    f.start_motion(sightings(held=True, px=0.3, reach=0.3))
    assert f.side == 18 and f.on_lattice(32).static.shape == (1, 18 * 18)
    loaded = lone()
    assert loaded.side == 32  # not carried: the whole field
    loaded.load_state_dict(f.state_dict())
    t = torch.tensor([0.3])
    assert loaded.side == 18
    torch.testing.assert_close(loaded.sdf(loaded.on_lattice(32), t), f.sdf(f.on_lattice(32), t), rtol=0, atol=0)


def test_unheld_centres_several_objects_and_the_static_rung_are_not_carried():
    f = lone()
    c, t = f.coefficients(XY), torch.tensor([0.0, 1.0])
    before = f.sdf(c, t)
    f.start_motion(sightings(held=False))
    torch.testing.assert_close(f.sdf(f.coefficients(XY), t), before, rtol=0, atol=0)
    for unmoved in (field(n_terms=3), lone(n_terms=0)):
        seen = sightings(held=True)
        if unmoved.n_objects == 2:
            seen = replace(seen, centres=seen.centres.expand(3, 2, 2), reach=seen.reach.expand(2))
        unmoved.start_motion(seen)
        assert not unmoved.describe()["carried"]


def test_frequencies_follow_seed_and_f_max():
    a, b, other = field(0, n_terms=4000, f_max=0.3), field(0, n_terms=4000, f_max=0.3), field(1, n_terms=4000, f_max=0.3)
    torch.testing.assert_close(a.omega, b.omega)
    assert not torch.equal(a.omega, other.omega)
    assert a.omega.std().item() == pytest.approx(0.3, rel=0.05)
    assert a.omega.mean().abs().item() < 0.02


def test_describe_counts_parameters():
    """n_params counts the shape g; a(k), one per object, is the model's too but not counted."""
    f = field(n_terms=3)
    assert f.describe()["n_params"] == sum(p.numel() for p in f.parameters()) - f.n_objects


def test_field_owns_its_intensities():
    f = field(n_terms=3)
    f.set_intensities(torch.tensor([0.25] * f.n_objects))
    torch.testing.assert_close(f.intensities, torch.full((f.n_objects,), 0.25))
    assert "log_intensities" in f.state_dict() and "signs" in f.state_dict()
    assert all(p is not f.log_intensities for p in f.shape_parameters())


def test_a_darker_nested_object_keeps_its_sign_while_its_magnitude_is_fitted():
    """a(k) starts at [1.0, -0.75] (a lung in a body): steps on the log-magnitude move both and
    never flip the sign, however hard the loss pulls the second through zero."""
    f = field(n_terms=3)  # two objects
    f.set_intensities(torch.tensor([1.0, -0.75]))
    torch.testing.assert_close(f.intensities, torch.tensor([1.0, -0.75]))
    opt = torch.optim.SGD([f.log_intensities], lr=0.5)
    for _ in range(20):
        opt.zero_grad()
        ((f.intensities - torch.tensor([1.2, 0.5])) ** 2).sum().backward()
        opt.step()
    a = f.intensities.detach()
    assert float(a[0]) == pytest.approx(1.2, abs=0.01)
    assert -0.1 < float(a[1]) < 0  # pulled towards +0.5, it shrinks towards 0 and stays negative


@pytest.mark.parametrize("key, value", [("family", "mlp"), ("width", 0), ("n_terms", -1), ("f_max", -0.1),
                                        ("omega0", 0.0)])
def test_bad_config_names_the_key(key, value):
    with pytest.raises(ValueError, match=f"model.{key}"):
        ModelConf(**{key: value})


GRID = dict(family="grid", resolution=16, temporal_resolution=8, levels=2)


def randomised(f):
    """The field with every parameter drawn at random (grids start at zero)."""
    with torch.no_grad():
        for p in f.parameters():
            p.normal_(generator=torch.Generator().manual_seed(p.numel()))
    return f


@pytest.mark.parametrize("family", ["siren", "grid"])
def test_lattice_evaluation_matches_points(family, device):
    """``on_lattice`` (separable matrix products for grids) gives the point-wise values at pixel centres."""
    from nct.acquisition.scanner import ImageGrid
    from nct.fields.lattice import lattice_points

    x, y = ImageGrid(24, 3.0).xy()
    centres = torch.from_numpy(np.stack([x.ravel(), y.ravel()], axis=1) / 1.5).float()
    torch.testing.assert_close(lattice_points(24), centres, atol=1e-6, rtol=0)
    f = (randomised(field(n_terms=3, **GRID)) if family == "grid" else field(n_terms=3)).to(device)
    a, b = f.coefficients(centres.to(device)), f.on_lattice(24)
    assert b.static.device.type == device.type
    torch.testing.assert_close(b.static, a.static, atol=1e-5, rtol=1e-5)
    torch.testing.assert_close(b.temporal, a.temporal, atol=1e-5, rtol=1e-5)


def test_grid_family_interpolates_its_nodes_bilinearly():
    """At a node the grid field is the sum of its levels there; halfway between it is the mean."""
    f = randomised(field(n_terms=0, **GRID))
    fine, coarse = (g[0, 0] for g in f.static.grids)  # 16 and 8 cells per side, object 0
    node = torch.tensor([[-1.0, -1.0], [1.0, 1.0]])
    torch.testing.assert_close(f.coefficients(node).static[0], torch.stack([fine[0, 0] + coarse[0, 0],
                                                                           fine[-1, -1] + coarse[-1, -1]]))
    half = torch.tensor([[-1 + 1 / 15, -1.0]])  # halfway between fine nodes 0 and 1 along x
    expected = (fine[0, 0] + fine[0, 1]) / 2 + coarse[0, 0] + (coarse[0, 1] - coarse[0, 0]) * (7 / 15) / 2
    torch.testing.assert_close(f.coefficients(half).static[0, 0], expected, atol=1e-6, rtol=1e-6)


def test_grid_family_sizes_and_validation():
    f = field(n_terms=4, **GRID)
    assert f.describe()["n_params"] == 2 * (16**2 + 8**2) + 2 * 4 * 2 * (8**2 + 4**2)
    assert isinstance(f, GridField) and f.describe()["static"] is False
    with pytest.raises(ValueError, match="model.resolution must be >= 2\\*\\*model.levels = 8"):
        ModelConf(family="grid", resolution=4, levels=3)
    with pytest.raises(ValueError, match="model.family must be one of"):
        ModelConf(family="hashgrid")


@pytest.mark.parametrize("n, size", [(16, 32), (5, 13), (64, 128)])
def test_upsample_is_bilinear_between_pixel_centres(n, size, device):
    """upsample equals torch's bilinear interpolation (align_corners=False) of the same images."""
    images = torch.randn(3, 2, n, n, dtype=torch.float64).to(device)
    expected = torch.nn.functional.interpolate(images, size=(size, size), mode="bilinear", align_corners=False)
    torch.testing.assert_close(upsample(images, size), expected, atol=2e-6, rtol=0)
