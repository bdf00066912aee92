"""Images and projections of the shapes: against the closed form and an independent projector
(skimage's radon), area-averaged images."""

import math

import numpy as np
import pytest
from scipy.integrate import quad
from skimage.transform import radon

from nct.acquisition.scanner import ImageGrid, Scanner
from nct.scenes.phantoms import (
    CircleConf,
    ComposedConf,
    EllipseConf,
    LettersConf,
    Signal,
    build_phantom,
)

T_ROT = 0.25


def rel_l2(a: np.ndarray, ref: np.ndarray) -> float:
    return float(np.linalg.norm(a - ref) / np.linalg.norm(ref))


def radon_rows(img: np.ndarray, angles: np.ndarray, pixel_size: float) -> np.ndarray:
    """skimage radon in the sinogram layout [V, n] and line-integral units (centre at n // 2)."""
    return radon(img, np.rad2deg(angles), circle=True).T * pixel_size


def test_centred_disc_matches_closed_form():
    r, intensity = 0.3, 2.0
    phantom = build_phantom(CircleConf(radius=r, orbit_radius=0.0, intensity=intensity), T_ROT)
    grid = ImageGrid(32)
    scanner = Scanner(views_per_rotation=8, rotations=1.0, rotation_time=T_ROT, n_bins=48, bin_spacing=1 / 40)
    sino = phantom.project(scanner, grid).astype(np.float64)
    s = scanner.bin_positions
    assert np.allclose(sino, sino[0], atol=1e-6)  # a centred disc looks the same from every angle

    chord = lambda u: 2 * intensity * math.sqrt(max(r * r - u * u, 0.0))
    # inside the disc a bin's mean departs from the centre value by ~ bin_spacing² / 24 · |chord''|
    interior = np.abs(s) < r - 2 * scanner.bin_spacing
    curvature = 2 * intensity * r**2 / (r**2 - s[interior] ** 2) ** 1.5
    error = np.abs(sino[0, interior] - [chord(u) for u in s[interior]])
    assert np.all(error <= 1.5 * scanner.bin_spacing**2 / 24 * curvature + 1e-6)
    half = scanner.bin_spacing / 2
    box = [quad(chord, u - half, u + half, points=[-r, r])[0] / scanner.bin_spacing for u in s]
    assert np.allclose(sino[0], box, atol=1e-5)


def test_rotated_offcentre_ellipse_matches_skimage_radon():
    conf = ComposedConf(objects=[EllipseConf(x=Signal(0.15), y=Signal(-0.1), a=Signal(0.2), b=Signal(0.08),
                                             angle_deg=Signal(30.0))])
    phantom = build_phantom(conf, T_ROT)
    grid = ImageGrid(65, extent=2.0)  # odd: radon's centre n // 2 is the geometric centre
    scanner = Scanner(views_per_rotation=24, rotations=0.5, rotation_time=T_ROT, n_bins=65,
                      bin_spacing=grid.pixel_size)
    img = phantom.image(0.0, grid, supersample=8)
    ref = radon_rows(img, scanner.angles, grid.pixel_size)
    sino = phantom.project(scanner, grid)
    assert rel_l2(sino, ref) < 0.03
    # the same comparison would catch a y flip or a reversed angle (both ~100 % off)
    assert rel_l2(sino, radon_rows(img[::-1], scanner.angles, grid.pixel_size)) > 0.5
    assert rel_l2(sino, radon_rows(img, -scanner.angles, grid.pixel_size)) > 0.5


def test_ellipse_image_is_area_averaged():
    conf = ComposedConf(objects=[EllipseConf(x=Signal(0.05), a=Signal(0.3), b=Signal(0.1), angle_deg=Signal(20.0),
                                             intensity=Signal(0.7))])
    img = build_phantom(conf, T_ROT).image(0.0, ImageGrid(48, extent=1.5), supersample=8)
    area = img.sum() * (1.5 / 48) ** 2 / 0.7
    assert area == pytest.approx(math.pi * 0.3 * 0.1 * 1.5**2, rel=5e-3)
    assert ((img > 0) & (img < 0.7)).any()  # partial-volume edge pixels


def test_letters_projection_matches_skimage_radon():
    phantom = build_phantom(LettersConf(sequence="A"), T_ROT)
    grid = ImageGrid(128, extent=1.5)
    scanner = Scanner(views_per_rotation=20, rotations=0.5, rotation_time=T_ROT, n_bins=128,
                      bin_spacing=grid.pixel_size)
    fine_grid = grid.refined(4)
    fine = phantom.image(0.0, fine_grid, supersample=1)
    ref_fine = radon_rows(fine, scanner.angles, fine_grid.pixel_size)
    s_fine = (np.arange(fine_grid.size) - fine_grid.size // 2) * fine_grid.pixel_size
    across_bin = scanner.bin_positions[:, None] + ((np.arange(16) + 0.5) / 16 - 0.5) * scanner.bin_spacing
    ref = np.stack([np.interp(across_bin, s_fine, row).mean(axis=1) for row in ref_fine])
    sino = phantom.project(scanner, grid)
    assert rel_l2(sino, ref) < 0.02
    assert sino.sum(axis=1) * scanner.bin_spacing == pytest.approx(fine.sum() * fine_grid.pixel_size**2, rel=1e-5)
