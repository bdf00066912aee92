"""TensorBoard: the HParams session carries the run's settings and real final metrics."""

import numpy as np
from tensorboard.backend.event_processing.event_accumulator import EventAccumulator
from tensorboard.plugins.hparams import plugin_data_pb2

from nct.pipeline import run_job
from nct.tracking import flat_hparams


def test_hparams_hold_settings_and_metrics(tiny_cfg, run_dir):
    cfg = tiny_cfg("method=fbp", "phantom.displacement_deg=40", "export.gif=false")
    run_job(cfg, run_dir)
    acc = EventAccumulator(str(run_dir / "tb"))
    acc.Reload()
    dice = acc.Scalars("hp/fbp_median_dice")[0].value
    assert 0.3 < dice <= 1.0
    content = acc.PluginTagToContent("hparams")
    start = plugin_data_pb2.HParamsPluginData.FromString(content["_hparams_/session_start_info"]).session_start_info
    assert start.hparams["phantom.displacement_deg"].number_value == 40.0
    assert start.hparams["method"].string_value == "fbp"
    assert acc.Tags()["images"], "no image grids written"


def test_flat_hparams_flattens_nested_config(tiny_cfg):
    flat = flat_hparams(tiny_cfg())
    assert flat["scanner.n_bins"] == 32 and flat["data.noise_i0"] == "None"
    assert all(isinstance(v, (bool, int, float, str)) for v in flat.values())
    assert np.isfinite(flat["loss.tv_space"])


def test_capacity_choice_is_in_metrics_and_tensorboard(tiny_cfg, run_dir):
    """capacity=auto: metrics.json and TensorBoard both say which rungs were fitted and why one was kept."""
    import json

    cfg = tiny_cfg("capacity=auto", "capacity.ladder=[0,4]", "model=grid", "model.resolution=32",
                   "model.temporal_resolution=8", "export.gif=false", "optim.init_steps=20", "optim.fit_steps=20")
    run_job(cfg, run_dir)
    capacity = json.loads((run_dir / "metrics.json").read_text())["capacity"]
    ladder = capacity["choice"]["ladder"]
    assert [r["n_terms"] for r in ladder] == [0, 4] and all(r["heldout_loss"] > 0 for r in ladder)
    assert capacity["n_terms"] in (0, 4) and capacity["family"] == "grid"
    acc = EventAccumulator(str(run_dir / "tb"))
    acc.Reload()
    assert [(e.step, round(e.value, 6)) for e in acc.Scalars("capacity/heldout_loss")] == [
        (r["n_terms"], round(r["heldout_loss"], 6)) for r in ladder]
    assert acc.Scalars("hp/n_terms")[0].value == capacity["n_terms"]
    text = acc.Tensors("capacity/text_summary")[0].tensor_proto.string_val[0].decode()
    assert capacity["choice"]["reason"] in text and "grid field" in text
