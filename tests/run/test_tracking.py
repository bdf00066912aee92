"""TensorBoard: the HParams session carries the run's overrides, a few identifying keys and real final metrics."""

import json
from pathlib import Path

import pytest
from tensorboard import context
from tensorboard.backend.event_processing import data_provider, plugin_event_multiplexer
from tensorboard.backend.event_processing.event_accumulator import EventAccumulator
from tensorboard.plugins import base_plugin
from tensorboard.plugins.hparams import api_pb2, backend_context, plugin_data_pb2

from nct.run.job import run_job
from nct.run.tracking import run_hparams

IDENTITY = {"method", "data.name", "phantom.name", "model.name", "seed"}


def hparams_tab(logdir: Path) -> api_pb2.Experiment:
    """The experiment TensorBoard's HParams plugin builds for ``logdir``: its columns (hparams, metrics)."""
    mux = plugin_event_multiplexer.EventMultiplexer()
    mux.AddRunsFromDirectory(str(logdir))
    mux.Reload()
    provider = data_provider.MultiplexerDataProvider(mux, str(logdir))
    backend = backend_context.Context(base_plugin.TBContext(logdir=str(logdir), multiplexer=mux,
                                                            data_provider=provider))
    ctx = context.RequestContext()
    return backend.experiment_from_metadata(ctx, "", True, backend.hparams_metadata(ctx, ""),
                                            backend.hparams_from_data_provider(ctx, "", 0))


def session_hparams(run_dir: Path) -> dict:
    acc = EventAccumulator(str(run_dir / "tb" / "hparams"))
    acc.Reload()
    content = acc.PluginTagToContent("hparams")["_hparams_/session_start_info"]
    start = plugin_data_pb2.HParamsPluginData.FromString(content).session_start_info
    return {k: getattr(v, v.WhichOneof("kind")) for k, v in start.hparams.items()}


def test_hparams_are_the_overrides_and_identity_keys_with_their_types(tiny_cfg, run_dir):
    """A NeuralCT run whose stages log ``epoch``: the HParams tab lists only the overrides, the identifying
    keys and the ``hp/*`` metrics; a boolean stays a boolean."""
    overrides = ["method=nct", "phantom.displacement_deg=40", "export.tiff=false", "trainer.log_every_n_steps=1",
                 "motion.tolerance=0.1", "export.gif=false", "hydra/launcher=basic", "resume=false"]
    run_job(tiny_cfg(*overrides), run_dir, overrides)
    values = session_hparams(run_dir)
    assert set(values) == IDENTITY | {"phantom.displacement_deg", "export.tiff", "trainer.log_every_n_steps",
                                      "motion.tolerance", "export.gif"}
    assert values["export.tiff"] is False and values["export.gif"] is False
    assert values["phantom.displacement_deg"] == 40.0 and values["seed"] == 0.0
    assert values["motion.tolerance"] == 0.1 and values["method"] == "nct" and values["phantom.name"] == "circle"

    stage = EventAccumulator(str(run_dir / "tb" / "free_init"))
    stage.Reload()
    assert "epoch" in stage.Tags()["scalars"]  # Lightning logs it per stage: the tab must not list it
    tab = hparams_tab(run_dir)
    assert {m.name.tag for m in tab.metric_infos} == {
        "hp/fbp_median_dice", "hp/fbp_median_mse", "hp/nct_median_dice", "hp/nct_median_mse", "hp/heldout_loss",
        "hp/wall_time_s", "hp/n_params", "hp/motion_ray_spread_px"}
    types = {h.name: h.type for h in tab.hparam_infos}
    assert types["export.tiff"] == api_pb2.DATA_TYPE_BOOL and types["seed"] == api_pb2.DATA_TYPE_FLOAT64
    acc = EventAccumulator(str(run_dir / "tb" / "hparams"))
    acc.Reload()
    assert 0.3 < acc.Scalars("hp/fbp_median_dice")[0].value <= 1.0
    frames = EventAccumulator(str(run_dir / "tb"))
    frames.Reload()
    assert frames.Tags()["images"], "no image grids written"
    assert frames.Scalars("motion/ray_spread_px")[0].value < 1.0 and "motion_determinacy/text_summary" in frames.Tags()["tensors"]


def test_swept_key_comes_first_in_the_tab(tiny_cfg, tmp_path):
    """Two runs side by side: the key whose value differs leads the table (TensorBoard sorts it first)."""
    for name, disp in (("a", 20), ("b", 60)):
        overrides = ["method=fbp", f"phantom.displacement_deg={disp}", "export.gif=false", "export.tiff=false",
                     "export.png=false"]
        run_job(tiny_cfg(*overrides), tmp_path / name, overrides)
    tab = hparams_tab(tmp_path)
    assert [(h.name, h.differs) for h in tab.hparam_infos][:2] == [("phantom.displacement_deg", True),
                                                                     ("data.name", False)]
    assert tab.hparam_infos[0].domain_interval.min_value == 20 and tab.hparam_infos[0].domain_interval.max_value == 60


def test_run_hparams_types_and_leaves_out_hydra_and_deletions(tiny_cfg):
    cfg = tiny_cfg("model=grid", "data.noise_i0=1e5")
    values = run_hparams(cfg, ["model=grid", "+phantom.extra=2.5", "data.noise_i0=null", "~threads",
                               "hydra.verbose=true", "hydra/launcher=basic", "export.png=true"])
    assert values == {"method": "nct", "data.name": "simulate", "phantom.name": "circle", "model.name": "grid",
                      "seed": 0, "model": "grid", "phantom.extra": 2.5, "data.noise_i0": "null", "export.png": True}
    assert list(values)[:5] == ["method", "data.name", "phantom.name", "model.name", "seed"]


def test_selection_is_in_metrics_selection_csv_and_tensorboard(tiny_cfg, run_dir):
    """motion.rungs [static, free]: metrics.json, selection.csv and TensorBoard all say which candidates
    were fitted, how far, and why one won."""
    cfg = tiny_cfg("motion.rungs=[static,free]", "motion.still_ratio=0", "model=grid", "model.resolution=32",
                   "model.temporal_resolution=8", "export.gif=false", "export.png=false", "export.tiff=false",
                   "optim.init_steps=20", "optim.fit_steps=20")
    run_job(cfg, run_dir)
    metrics = json.loads((run_dir / "metrics.json").read_text())
    selection, model = metrics["selection"], metrics["model"]
    assert [r["candidate"] for r in selection["table"]] in (["static", "free"], ["free", "static"])
    assert all(r["heldout_misfit"] > 0 for r in selection["table"])
    assert model["motion"] == selection["rung"] and model["family"] == "grid"
    assert sum(r["verdict"] == "winner" for r in selection["table"]) == 1
    acc = EventAccumulator(str(run_dir / "tb"))
    acc.Reload()
    text = acc.Tensors("selection/text_summary")[0].tensor_proto.string_val[0].decode()
    assert selection["reason"] in text and f"{model['motion']} motion, grid field" in text
    assert "| candidate | rung | steps | held-out misfit | verdict |" in text
    session = EventAccumulator(str(run_dir / "tb" / "hparams"))
    session.Reload()
    assert session.Scalars("hp/n_params")[0].value == model["n_params"]


def test_phases_are_in_tensorboard_with_each_candidates_fit(tiny_cfg, run_dir):
    """Where the time went: a table as text, a row per candidate's stage under the fits, and a scalar per
    phase, the tournament split into fits (its stages' own time, metrics.json ``stages``) and selection."""
    run_job(tiny_cfg("motion.rungs=[static,free]", "motion.still_ratio=0", "optim.init_steps=5", "optim.fit_steps=5",
                     "export.gif=false", "export.png=false", "export.tiff=false"), run_dir)
    metrics = json.loads((run_dir / "metrics.json").read_text())
    acc = EventAccumulator(str(run_dir / "tb"))
    acc.Reload()
    text = acc.Tensors("phases/text_summary")[0].tensor_proto.string_val[0].decode()
    assert "| phase | wall s | CPU s | share of wall |" in text
    assert all(f"| · {stage} |" in text for stage in ("static_init", "static_fit", "free_init", "free_fit"))
    scalars = {tag: acc.Scalars(tag)[0].value for tag in acc.Tags()["scalars"] if tag.startswith("phases/")}
    wall = metrics["phases"]["wall_s"]
    assert set(scalars) == {f"phases/{p}" for p in wall if p != "tournament"} | {"phases/fits", "phases/selection"}
    fits = sum(s["wall_time_s"] for s in metrics["stages"].values())
    assert scalars["phases/fits"] == pytest.approx(fits, rel=1e-5)
    assert scalars["phases/fits"] + scalars["phases/selection"] == pytest.approx(wall["tournament"], rel=1e-5)


def test_stages_log_previews_residuals_and_heldout_validation(tiny_cfg, run_dir):
    """The image callback draws each stage's frames (and SinogramFit's residual) from its field;
    SinogramFit's held-out views are scored as Lightning validation."""
    run_job(tiny_cfg("method=nct", "heldout.check_every=2", "export.gif=false", "export.tiff=false",
                     "export.png=false"), run_dir)
    init, fit = (EventAccumulator(str(run_dir / "tb" / name)) for name in ("free_init", "free_fit"))
    init.Reload(), fit.Reload()
    assert set(init.Tags()["images"]) == {"free_init/frames"}
    assert set(fit.Tags()["images"]) == {"free_fit/frames", "free_fit/sinogram_residual"}
    held = fit.Scalars("val/heldout_loss")
    # After steps 2 and 4 of 5; Lightning files them under the last training step's 0-based index. (Five
    # steps of a tiny field need not lower it: from the compensated start it read 0.574 then 0.598.)
    assert [s.step for s in held] == [1, 3] and all(0 < s.value < 1 for s in held)
