"""A run beyond this machine's memory is refused before allocating, in one line naming the key."""

import numpy as np
import pytest

from nct.errors import InputError
from nct.run import memory
from nct.run.config import validate
from tests.conftest import compose_config


def test_sizes_beyond_the_memory_are_refused_before_allocating(nct, tmp_path, monkeypatch):
    """image.size=100000 would need ~11 TiB (the simulated truth alone: 1150 bytes a pixel): one line
    naming the key, for a simulation at validation and for a file once its sizes are read."""
    quick = ["debug=tiny", "logger=none", "method=fbp"]
    code, _, err = nct(*quick, "image.size=100000")
    assert code == 2 and err.count("\n") == 1
    assert err.startswith("nct: error: image.size=100000: the run would need about 11.3 TiB of memory "
                          "(100000x100000 pixels, 6 frames, 60 views x 32 bins), more than this machine's ")
    code, _, err = nct(*quick, "scanner.views_per_rotation=100000000", "scanner.n_bins=100000")
    assert code == 2 and err.startswith("nct: error: scanner.views_per_rotation=100000000: the run would need")
    angles = np.linspace(0, np.pi, 20)
    np.savez(tmp_path / "scan.npz", sinogram=np.ones((20, 16), np.float32), angles=angles, times=angles,
             bin_spacing=0.1)
    code, _, err = nct(*quick, "data=file", f"data.path={tmp_path / 'scan.npz'}", "image.size=100000")
    assert code == 2 and err.startswith("nct: error: image.size=100000: the run would need about")
    # The default run: 128^2 pixels x (1150 + 16 x 36 frames + 128 x 20 views) + 16 x 720 x 128 bytes = 68.4 MiB.
    monkeypatch.setattr(memory, "physical_memory", lambda: 69 * 2**20)
    validate(compose_config([]))
    monkeypatch.setattr(memory, "physical_memory", lambda: 68 * 2**20)
    with pytest.raises(InputError, match=r"^image\.size=128: the run would need about 68\.4 MiB .* machine's 68 MiB$"):
        validate(compose_config([]))


def test_a_large_image_fitted_small_is_sized_by_the_grid_it_fits(monkeypatch):
    """512^2 pixels x (1150 + 16 x 36 frames) + 16 x 720 x 512 bytes = 477 MiB with the fit on 128^2 pixels
    (128 x 20 views a pixel: 40 MiB); fitted at 512^2 the fit alone would need 640 MiB."""
    big = ["image.size=512", "scanner.n_bins=512"]
    monkeypatch.setattr(memory, "physical_memory", lambda: 478 * 2**20)
    validate(compose_config([*big, "optim.fit_size=128"]))
    with pytest.raises(InputError, match=r"^image\.size=512: the run would need about 1\.05 GiB"):
        validate(compose_config(big))
    monkeypatch.setattr(memory, "physical_memory", lambda: 476 * 2**20)
    with pytest.raises(InputError, match=r"^image\.size=512: the run would need about 477 MiB"):
        validate(compose_config([*big, "optim.fit_size=128"]))
