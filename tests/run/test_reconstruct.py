"""run/reconstruct.py: a scan at least twice ``optim.fit_size`` is fitted on its views binned to that size, and its
frames are the fitted field drawn at the scan's own size."""

from __future__ import annotations

import numpy as np

from nct.acquisition.scan import Scan, output_grid
from nct.run.config import validate
from nct.run.reconstruct import reconstruct_scan
from tests.conftest import TINY, compose_config, moving_disc

SETTINGS = TINY + ["threads=1", "background=image", "callbacks.snapshot_every_n_steps=5"]


def test_a_large_scan_is_fitted_small_and_drawn_at_its_own_size():
    sino = moving_disc()[0]
    scan = Scan.of(sino, *output_grid(sino), simulated=True)  # 32 px, 32 bins
    rec = reconstruct_scan(scan, validate(compose_config(SETTINGS + ["optim.fit_size=16"])))
    small = scan.to_fit(16)
    alone = reconstruct_scan(small, validate(compose_config(SETTINGS)))  # the same fit, asked of the binned views
    assert rec.record["fitted_on"] == {"n_bins": 16, "size": 16} and "fitted_on" not in alone.record
    assert rec.frames.shape == rec.fbp.shape == (6, 32, 32) and rec.masks.shape == (6, 1, 32, 32)
    assert rec.background.shape == (32, 32) and rec.trace[-1].frames.shape == (6, 32, 32)
    for ours, theirs in zip(rec.render(rec.times), alone.render(rec.times, 32)):  # the same field, drawn large
        np.testing.assert_array_equal(ours, theirs)
    np.testing.assert_array_equal(rec.render(rec.times)[0], rec.frames)
    assert rec.selection == alone.selection and rec.record["heldout_loss"] == alone.record["heldout_loss"]
    assert rec.record["heldout_fbp_loss"] == alone.record["heldout_fbp_loss"]  # the warnings read the views fitted
    assert rec.metrics()["nct"].dice.shape == (6,)
