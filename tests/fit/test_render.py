"""Occupancy, intensity and the supersampled projection against a disc's exact line integrals."""

from __future__ import annotations

import math

import numpy as np
import pytest
import torch

from nct.acquisition.geometry import ParallelGeometry
from nct.acquisition.scanner import ImageGrid
from nct.fit.render import intensity, occupancy, project_frames

GRID = ImageGrid(64)
RADIUS, CX, CY = 0.2, 0.08, -0.05
ANGLES = torch.tensor([0.0, 0.7, 1.9, 3.0])
N_BINS, SPACING = 64, 1 / 64
GEOMETRY = ParallelGeometry(N_BINS, SPACING)


def disc_sdf() -> torch.Tensor:
    x, y = GRID.xy()
    return torch.from_numpy(RADIUS - np.hypot(x - CX, y - CY)).float()


def disc_projection() -> np.ndarray:
    """Exact mean over each bin's width of the chord 2 sqrt(r^2 - s^2): [4, N_BINS]."""
    edges = (np.arange(N_BINS + 1) - N_BINS / 2) * SPACING
    centre = CX * np.cos(ANGLES.numpy()) + CY * np.sin(ANGLES.numpy())
    s = np.clip(edges[None, :] - centre[:, None], -RADIUS, RADIUS)
    area = s * np.sqrt(RADIUS**2 - s**2) + RADIUS**2 * np.arcsin(s / RADIUS)  # antiderivative of the chord
    return np.diff(area, axis=1) / SPACING


def test_occupancy_ramp_is_centred_and_band_wide():
    band = 0.1
    g = torch.tensor([-1.0, -band / 2, -0.01, 0.0, 0.01, band / 2, 1.0])
    z = occupancy(g, band, mu=50.0)
    assert z[0] == 0 and z[1] == pytest.approx(0, abs=1e-5) and z[-1] == 1 and z[-2] == pytest.approx(1, abs=1e-5)
    assert z[3] == pytest.approx(0.5) and 0.3 < z[2] < 0.5 < z[4] < 0.7
    # inside the ramp, the paper's sigmoid is close to linear
    assert z[4].item() == pytest.approx(0.5 + 0.01 / band, abs=0.01)


def test_intensity_sums_objects():
    sdf = torch.stack([disc_sdf(), -disc_sdf()])[None]  # disc and its complement
    img = intensity(sdf, torch.tensor([1.0, 0.25]), GRID.pixel_size, 50.0)
    assert img.shape == (1, 64, 64)
    assert img.max().item() == pytest.approx(1.0) and img.min().item() == pytest.approx(0.25)


@pytest.mark.parametrize("k_samp", [1, 2])
def test_projection_matches_exact_disc_integrals(k_samp, device):
    sdf = disc_sdf()[None, None].expand(len(ANGLES), 1, -1, -1).to(device)
    sino = project_frames(sdf, torch.ones(1, device=device), ANGLES.to(device), GEOMETRY, GRID.extent,
                          GRID.pixel_size, 50.0, k_samp).cpu()
    assert sino.dtype == torch.float32
    exact = disc_projection()
    error = np.abs(sino.numpy() - exact).mean() / exact.mean()
    assert error < 0.01
    assert sino.sum(1).numpy() * SPACING == pytest.approx(math.pi * RADIUS**2, rel=0.01)


def test_gradient_reaches_the_band_only():
    sdf = disc_sdf()[None, None].clone().requires_grad_(True)
    project_frames(sdf, torch.ones(1), ANGLES[:1], GEOMETRY, GRID.extent, 4 * GRID.pixel_size, 50.0).sum().backward()
    grad = sdf.grad[0, 0].abs()
    near = disc_sdf().abs() < 1.5 * GRID.pixel_size
    far = disc_sdf().abs() > 2.5 * GRID.pixel_size
    assert (grad[near] > 0).all() and (grad[far] == 0).all()


def test_bad_arguments():
    with pytest.raises(ValueError, match="band"):
        occupancy(torch.zeros(3), 0.0, 50.0)
    with pytest.raises(ValueError, match="k_samp"):
        project_frames(torch.zeros(1, 1, 8, 8), torch.ones(1), torch.zeros(1), ParallelGeometry(8, 0.125), 1.0, 0.1, 50.0, 0)
