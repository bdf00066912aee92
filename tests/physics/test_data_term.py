"""The sinogram data term: L1 and the Poisson-aware Huber term, the noise model and the I0 estimate."""

import math
from dataclasses import replace

import numpy as np
import pytest
import torch

from nct.acquisition.scanner import ImageGrid, Scanner
from nct.acquisition.sinogram import Sinogram
from nct.fit.units import Units
from nct.physics.data_term import estimate_i0, misfit, noise_std, view_noise
from nct.scenes.phantoms import CircleConf, build_phantom
from nct.scenes.simulate import add_poisson_noise, attenuation_scale, simulate

RENDER = torch.tensor([[1.0, 2.0, 0.0]])
VALUES = torch.tensor([[0.0, 4.0, 0.5]])


def test_l1_by_hand():
    # |r| = 1, 2, 0.5 -> mean 3.5 / 3, relative to scale 2
    assert float(misfit(RENDER, VALUES, None, 2.0)) == pytest.approx(3.5 / 3 / 2)


def test_poisson_huber_by_hand():
    # r = 1 within sigma 2: 1² / (2·2) = 0.25; r = 2 beyond sigma 1: 2 - 0.5 = 1.5; r = 0.5 at sigma 0.5: 0.25
    sigma = torch.tensor([[2.0, 1.0, 0.5]])
    assert float(misfit(RENDER, VALUES, sigma, 2.0)) == pytest.approx((0.25 + 1.5 + 0.25) / 3 / 2)


def test_noiseless_poisson_term_is_l1_with_finite_gradients():
    render = RENDER.clone().requires_grad_()
    loss = misfit(render, VALUES, torch.zeros(1, 3), 2.0)
    assert torch.equal(loss, misfit(RENDER, VALUES, None, 2.0))
    loss.backward()
    assert torch.equal(render.grad, torch.tensor([[1.0, -1.0, -1.0]]) / 6)


def test_noise_std_by_hand_and_against_poisson_draws():
    # k = 2, I0 = 100: sigma(0) = 1 / (2·10); at p = 1 photons fall by e², sigma by e
    assert noise_std(np.array([0.0, 1.0]), 100.0, 2.0) == pytest.approx([0.05, 0.05 * math.e], rel=1e-6)
    extent, i0, p = 1.0, 1e4, 0.3
    draws = add_poisson_noise(np.full((400, 500), p), i0, extent, np.random.default_rng(0))
    expected = noise_std(np.array([[p]]), i0, attenuation_scale(extent))[0, 0]
    assert draws.std() == pytest.approx(expected, rel=0.02)


def circle_sinogram(i0: float | None, views: int = 720) -> Sinogram:
    scanner = Scanner(views, 1.0, 0.25, 0.0, 64, 1 / 64)
    phantom = build_phantom(CircleConf(radius=0.15, displacement_deg=150), 0.25)
    return simulate(phantom, scanner, ImageGrid(64, 1.0), np.array([0.1]), i0, np.random.default_rng(1))


@pytest.mark.parametrize("i0", [3e2, 1e4, 1e5])
def test_i0_estimated_from_the_data_within_5_percent(i0):
    assert estimate_i0(circle_sinogram(i0).values, attenuation_scale(1.0)) == pytest.approx(i0, rel=0.05)


def test_noiseless_data_estimate_no_noise():
    assert estimate_i0(circle_sinogram(None).values, attenuation_scale(1.0)) == math.inf


def test_view_noise_in_the_method_units():
    """The same data in mm (FOV 250 mm, its attenuation k per mm) mapped into the method's units
    (intensity unit 0.8): the noise std of the data's own units, rescaled; I0 estimated from the
    data gives it within 5 %."""
    sino = circle_sinogram(1e4)
    assert sino.attenuation == attenuation_scale(1.0)
    assert view_noise(sino, "l1") is None
    units = Units(250.0, 0.8)
    mm = Sinogram(sino.values * np.float32(250.0), sino.angles, sino.times, sino.geometry.scaled(250.0), i0=1e4,
                  attenuation=attenuation_scale(250.0))
    given = view_noise(units.sinogram(mm), "poisson")
    in_mm = noise_std(mm.values, 1e4, attenuation_scale(250.0)) / (0.8 * 250.0)
    np.testing.assert_allclose(given.numpy(), in_mm, rtol=1e-4)
    estimated = view_noise(units.sinogram(replace(mm, i0=None)), "poisson")
    torch.testing.assert_close(estimated, given, rtol=0.05, atol=0)
