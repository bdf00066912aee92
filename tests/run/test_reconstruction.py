"""The Reconstruction (run/reconstruction.py): saved and loaded with equal arrays and a field that renders
alike, scored against a truth, and refused in one line where it cannot do what is asked."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from nct.acquisition.scan import Scan, output_grid
from nct.errors import InputError
from nct.run.config import validate
from nct.run.metrics import frame_metrics
from nct.run.reconstruct import reconstruct_scan
from nct.run.reconstruction import Reconstruction, load_reconstruction
from tests.conftest import TINY, compose_config, moving_disc


def disc_scan() -> Scan:
    sino = moving_disc()[0]
    return Scan.of(sino, *output_grid(sino), simulated=True)


@pytest.fixture(scope="module")
def rec() -> Reconstruction:
    """A tiny NeuralCT fit of the moving disc with a background image (every part a reconstruction has), its field
    drawn on a lattice coarser than the image as the default run's is (optim.coarse_size)."""
    return reconstruct_scan(disc_scan(), validate(compose_config(TINY + ["background=image", "threads=1",
                                                                         "optim.coarse_size=16"])))


@pytest.fixture(scope="module")
def fbp_only() -> Reconstruction:
    return reconstruct_scan(disc_scan(), validate(compose_config(TINY + ["method=fbp"])))


def test_save_and_load_give_equal_arrays_records_and_renders(rec, tmp_path):
    again = load_reconstruction(rec.save(tmp_path / "saved"))
    for name in ("frames", "fbp", "masks", "background", "times"):
        np.testing.assert_array_equal(getattr(again, name), getattr(rec, name), err_msg=name)
        assert getattr(again, name).dtype == getattr(rec, name).dtype
    assert again.extent == rec.extent and again.scan.grid == rec.scan.grid and again.scan.simulated
    np.testing.assert_array_equal(again.scan.sinogram.values, rec.scan.sinogram.values)
    np.testing.assert_array_equal(again.scan.truth.frames, rec.scan.truth.frames)
    assert again.selection == rec.selection and again.warnings == rec.warnings and again.record == rec.record
    times = np.array([0.01, 0.1, 0.24])
    for size in (None, 50):
        for ours, theirs in zip(again.render(times, size), rec.render(times, size)):
            np.testing.assert_array_equal(ours, theirs)
    frames, sdf = rec.render(times, 50)
    assert frames.shape == (3, 50, 50) and sdf.shape == (3, 1, 50, 50) and frames.dtype == np.float32


def test_the_field_renders_the_frames_at_their_own_times_and_size(rec):
    """The fit drew its frames on a 16-point lattice interpolated to 32 px: render draws the field so."""
    frames, sdf = rec.render(rec.times)
    np.testing.assert_allclose(frames, rec.frames, rtol=0, atol=1e-5 * float(np.abs(rec.frames).max()))
    np.testing.assert_array_equal((sdf > 0)[np.abs(sdf) > 1e-4], rec.masks[np.abs(sdf) > 1e-4])


def test_metrics_score_each_method_against_the_scans_truth_or_a_given_one(rec):
    truth = rec.scan.truth
    scores = rec.metrics()
    assert list(scores) == ["fbp", "nct"]
    np.testing.assert_array_equal(scores["nct"].dice, frame_metrics(rec.frames, truth.frames, truth.level).dice)
    empty = replace(truth, frames=np.zeros_like(truth.frames))
    assert np.all(rec.metrics(empty)["nct"].mse > scores["nct"].mse)
    with pytest.raises(InputError, match=r"truth frames of shape \(1, 32, 32\), the reconstruction's \(6, 32, 32\)"):
        rec.metrics(replace(truth, frames=truth.frames[:1]))


def test_fbp_only_has_no_field_and_saves_and_loads_so(fbp_only, tmp_path):
    assert fbp_only.frames is None and fbp_only.masks is None and fbp_only.fitted is None
    assert fbp_only.selection == [] and list(fbp_only.methods()) == ["fbp"]
    again = load_reconstruction(fbp_only.save(tmp_path / "fbp"))
    np.testing.assert_array_equal(again.fbp, fbp_only.fbp)
    assert again.fitted is None and not (tmp_path / "fbp" / "checkpoints").exists()
    with pytest.raises(InputError, match="FBP-only reconstruction"):
        again.render(again.times)


@pytest.mark.parametrize("call, says", [
    (lambda r: r.render([0.1, 9.0]), "render: times 9 lies outside the acquisition, 0 s to 0.25 s"),
    (lambda r: r.render([0.1], size=1), "render: size must be a whole number >= 2"),
    (lambda r: replace(r, scan=Scan.of(replace(r.scan.sinogram, truth=None), r.scan.grid, r.times)).metrics(),
     "the scan holds no truth to score against"),
])
def test_what_cannot_be_done_is_one_line(rec, call, says):
    with pytest.raises(InputError) as err:
        call(rec)
    assert says in str(err.value) and "\n" not in str(err.value)


def test_a_folder_is_saved_into_once_and_only_a_saved_one_loads(rec, tmp_path: Path):
    rec.save(tmp_path / "once")
    before = (tmp_path / "once" / "reconstruction.npz").read_bytes()
    with pytest.raises(InputError, match="holds a reconstruction already"):
        rec.save(tmp_path / "once")
    assert (tmp_path / "once" / "reconstruction.npz").read_bytes() == before
    with pytest.raises(InputError, match="holds no saved reconstruction"):
        load_reconstruction(tmp_path)
