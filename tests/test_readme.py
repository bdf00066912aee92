"""The README's "Bring your own data" example runs as written and its four files load to one scan."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from nct.acquisition.io import load_sinogram
from nct.errors import InputError

README = Path(__file__).resolve().parents[1] / "README.md"


def example_code() -> str:
    section = README.read_text().split("### Bring your own data", 1)[1]
    return re.search(r"```python\n(.*?)```", section, re.S).group(1)


def test_the_example_writes_files_that_load_to_the_same_scan(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    exec(compile(example_code(), "README.md", "exec"), {})
    parallel, fan, raw, tiff = (load_sinogram(tmp_path / name) for name in
                                ("parallel.npz", "fan.npz", "raw.npz", "scan.tif"))
    assert parallel.geometry.keys() == {"bin_spacing": 0.8, "detector_offset": 0.0}
    assert fan.geometry == raw.geometry == tiff.geometry and fan.geometry.detector_offset == 3.2
    np.testing.assert_allclose(fan.angles, parallel.angles, rtol=1e-12)  # degrees in the file
    # Counts at I0 = 5e4: the Poisson noise of -log(counts / I0) is 1 / sqrt(counts) <= 0.0064 here.
    assert np.abs(raw.values - fan.values).max() < 0.04
    assert np.sqrt(np.mean((raw.values - fan.values) ** 2)) < 0.006
    np.testing.assert_array_equal(tiff.values, raw.values)  # whole counts: the uint16 stack loses nothing
    assert raw.i0 == tiff.i0 == pytest.approx(5e4)
    with np.load(tmp_path / "fan.npz") as data:
        np.savez(tmp_path / "bad.npz", **(dict(data) | {"detector_distance": np.float64(-400.0)}))
    with pytest.raises(InputError, match=r"key 'detector_distance': expected a finite positive number, got -400\.0$"):
        load_sinogram(tmp_path / "bad.npz")
