"""The README is a short guide whose pictures and links exist; docs/DATA.md's "Bring your own data"
example runs as written and its four files load to one scan."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from nct.acquisition.io import load_sinogram
from nct.errors import InputError

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
DATA = ROOT / "docs" / "DATA.md"
LINK = re.compile(r"(!?)\[[^\]]*\]\(([^)\s]+)\)")  # markdown [text](target) and ![alt](image)


def local_links(markdown: Path) -> list[tuple[bool, str]]:
    """(is an image, target) of each link in ``markdown`` that is not a URL; targets may end in #anchor."""
    return [(bang == "!", target) for bang, target in LINK.findall(markdown.read_text())
            if not re.match(r"[a-z]+:", target) and not target.startswith("#")]


def anchors(markdown: Path) -> set[str]:
    """The #anchors GitHub gives the headings of ``markdown``: lower case, punctuation dropped, - for spaces."""
    headings = re.findall(r"^#+ (.+)$", markdown.read_text(), re.M)
    return {re.sub(r"[^\w\- ]", "", h.strip().lower()).replace(" ", "-") for h in headings}


def example_code() -> str:
    section = DATA.read_text().split("## Bring your own data", 1)[1]
    return re.search(r"```python\n(.*?)```", section, re.S).group(1)


def test_the_readme_is_at_most_10_kb():
    assert README.stat().st_size <= 10_000


def test_every_picture_and_link_of_the_readme_exists():
    links = local_links(README)
    images = [target for image, target in links if image]  # no anchors
    assert images, "the README shows the outputs of a run"
    for image, target in links:
        file, _, anchor = target.partition("#")
        path = README.parent / file
        assert path.is_file() if image else path.exists(), f"README.md links {file}, which does not exist"
        assert not anchor or anchor in anchors(path), f"README.md links {target}: {file} has no such heading"
    for target in images:
        assert target.endswith(".png") and (README.parent / target).stat().st_size < 300_000, target


def test_the_example_writes_files_that_load_to_the_same_scan(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    exec(compile(example_code(), "docs/DATA.md", "exec"), {})
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
