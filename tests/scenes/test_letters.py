"""The letters' pixel-driven projection against an independent projector (skimage's radon) of a finer
rasterisation, and its mass against the image's."""

import numpy as np
import pytest

from nct.acquisition.scanner import ImageGrid, Scanner
from nct.scenes.phantoms import LettersConf, build_phantom
from tests.conftest import radon_rows, rel_l2

T_ROT = 0.25


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
