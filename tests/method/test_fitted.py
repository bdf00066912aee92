"""The field file (method/fitted.py): a field saved with what rebuilds it loads with every tensor, and a
file that is missing, not one or from an older nct is refused in one line."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import torch

from nct.acquisition.scanner import ImageGrid
from nct.errors import InputError
from nct.fields.build import FieldSpec
from nct.fit.conf import RenderConf
from nct.fit.problem import Clock
from nct.fit.units import Units
from nct.method.fitted import FittedField, acquisition_span, load_field, save_field
from tests.conftest import MODEL


@pytest.mark.parametrize("rung, background", [("free", None), ("rigid", (8, 8))])
def test_a_saved_field_loads_with_every_tensor_and_setting(tmp_path: Path, rung, background):
    spec = FieldSpec(MODEL, rung, 2, 1.5, background)
    net = spec.build()
    with torch.no_grad():
        for value in net.state_dict().values():
            if value.is_floating_point():
                value.uniform_(-1, 1)  # any weights: the file must carry them, not rebuild them
    fitted = FittedField(net, spec, Units(2.0, 3.0), ImageGrid(24, 2.0), Clock(0.1, 4.0), (0.1, 0.6),
                         RenderConf(band_px=1.5), 12)
    save_field(tmp_path / "checkpoints" / "field.pt", fitted)
    again = load_field(tmp_path / "checkpoints" / "field.pt")
    assert (again.spec, again.units, again.grid, again.clock, again.span, again.render, again.lattice) == \
        (spec, fitted.units, fitted.grid, fitted.clock, fitted.span, fitted.render, 12)
    for key, value in net.state_dict().items():
        torch.testing.assert_close(again.field.state_dict()[key], value, rtol=0, atol=0)


def test_building_leaves_the_callers_random_streams_alone():
    torch.manual_seed(5)
    expected = torch.rand(3)
    torch.manual_seed(5)
    FieldSpec(MODEL, "free", 1, 1.0).build()
    torch.testing.assert_close(torch.rand(3), expected, rtol=0, atol=0)


def test_a_missing_foreign_or_older_file_is_refused(tmp_path: Path):
    path = tmp_path / "checkpoints" / "field.pt"
    with pytest.raises(InputError, match="holds no checkpoint of its fitted field"):
        load_field(path)
    path.parent.mkdir()
    path.write_bytes(b"not a checkpoint")
    with pytest.raises(InputError, match="is not a field file of this nct"):
        load_field(path)
    spec = FieldSpec(MODEL, "free", 1, 1.0)
    fitted = FittedField(spec.build(), spec, Units(1.0), ImageGrid(8), Clock(0.0, 4.0), (0.0, 0.25), RenderConf(), 8)
    save_field(path, fitted)
    saved = torch.load(path, weights_only=True)
    saved["state_dict"].pop("omega")
    torch.save(saved, path)
    with pytest.raises(InputError, match=r"written by an older nct \(its checkpoint has no omega\)"):
        load_field(path)


def test_the_acquisition_spans_the_last_views_slot():
    assert acquisition_span(np.array([0.0, 0.1, 0.2])) == pytest.approx((0.0, 0.3))
