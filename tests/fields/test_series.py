"""Motion series over a scan (series.py): the Legendre terms are numpy's to the last bit wherever the
times lie, and a fit of them gives back a series' coefficients."""

from __future__ import annotations

import pytest
import torch
from numpy.polynomial.legendre import legvander

from nct.fields.conf import ModelConf
from nct.fields.series import legendre, legendre_fit, on_scan, series_terms


@pytest.mark.parametrize("n", [1, 2, 3, 6, 9])
def test_legendre_terms_are_numpys_bit_for_bit_and_laid_out_alike(n):
    s = torch.rand(257, generator=torch.Generator().manual_seed(n)) * 2 - 1
    expected = legvander(s.double().numpy(), n - 1)
    assert legendre(s.double(), n).numpy().tobytes() == expected.tobytes()
    ours, numpys = legendre(s, n), torch.from_numpy(expected).to(s)
    assert torch.equal(ours, numpys) and ours.stride() == numpys.stride()  # products round as with numpy's


def test_a_fit_gives_back_a_series_and_times_map_onto_the_scan():
    t = torch.linspace(0, 1.5, 40, dtype=torch.float64)
    s = on_scan(t, torch.tensor(1.5, dtype=torch.float64))
    assert float(s[0]) == -1 and float(s[-1]) == 1
    coefficients = torch.tensor([[0.3, -1.0], [0.2, 0.5], [-0.1, 0.05]], dtype=torch.float64)
    torch.testing.assert_close(legendre_fit(s, legendre(s, 3) @ coefficients, 3), coefficients)
    assert series_terms(ModelConf(pose_terms_per_rotation=2.0), 1.5) == 3
    assert series_terms(ModelConf(pose_terms_per_rotation=1.0), 0.5) == 2  # at least a line
