"""TensorBoard: the HParams session carries the run's overrides, a few identifying keys and real final metrics."""

import json
from pathlib import Path

from tensorboard import context
from tensorboard.backend.event_processing import data_provider, plugin_event_multiplexer
from tensorboard.backend.event_processing.event_accumulator import EventAccumulator
from tensorboard.plugins import base_plugin
from tensorboard.plugins.hparams import api_pb2, backend_context, plugin_data_pb2

from nct.run.job import run_job
from nct.run.tables import fmt
from nct.run.tracking import run_hparams, write_capacity

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
                 "capacity.ladder=[0,4]", "export.gif=false", "hydra/launcher=basic", "resume=false"]
    run_job(tiny_cfg(*overrides), run_dir, overrides)
    values = session_hparams(run_dir)
    assert set(values) == IDENTITY | {"phantom.displacement_deg", "export.tiff", "trainer.log_every_n_steps",
                                      "capacity.ladder", "export.gif"}
    assert values["export.tiff"] is False and values["export.gif"] is False
    assert values["phantom.displacement_deg"] == 40.0 and values["seed"] == 0.0
    assert values["capacity.ladder"] == "[0, 4]" and values["method"] == "nct" and values["phantom.name"] == "circle"

    stage = EventAccumulator(str(run_dir / "tb" / "init"))
    stage.Reload()
    assert "epoch" in stage.Tags()["scalars"]  # Lightning logs it per stage: the tab must not list it
    tab = hparams_tab(run_dir)
    assert {m.name.tag for m in tab.metric_infos} == {
        "hp/fbp_median_dice", "hp/fbp_median_mse", "hp/nct_median_dice", "hp/nct_median_mse", "hp/heldout_loss",
        "hp/wall_time_s", "hp/n_terms", "hp/n_params", "hp/motion_ray_spread_px"}
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


def test_capacity_choice_is_in_metrics_and_tensorboard(tiny_cfg, run_dir):
    """capacity=auto: metrics.json and TensorBoard both say which rungs were fitted and why one was kept."""
    cfg = tiny_cfg("capacity=auto", "capacity.ladder=[0,4]", "model=grid", "model.resolution=32",
                   "model.temporal_resolution=8", "export.gif=false", "export.png=false", "export.tiff=false",
                   "optim.init_steps=20", "optim.fit_steps=20")
    run_job(cfg, run_dir)
    capacity = json.loads((run_dir / "metrics.json").read_text())["capacity"]
    ladder = capacity["choice"]["ladder"]
    assert [r["n_terms"] for r in ladder] == [0, 4] and all(r["heldout_loss"] > 0 for r in ladder)
    assert capacity["n_terms"] in (0, 4) and capacity["family"] == "grid"
    acc = EventAccumulator(str(run_dir / "tb"))
    acc.Reload()
    assert [(e.step, round(e.value, 6)) for e in acc.Scalars("capacity/heldout_loss")] == [
        (r["n_terms"], round(r["heldout_loss"], 6)) for r in ladder]
    session = EventAccumulator(str(run_dir / "tb" / "hparams"))
    session.Reload()
    assert session.Scalars("hp/n_terms")[0].value == capacity["n_terms"]
    text = acc.Tensors("capacity/text_summary")[0].tensor_proto.string_val[0].decode()
    assert capacity["choice"]["reason"] in text and "grid field" in text
    assert "| terms | held-out loss | parameters |\n|---|---|---|\n| 0 | " in text
    obj = capacity["objects"]["per_object"][0]
    assert f"object 0: boundary motion {fmt(obj['motion_px'])} px after the fit: {obj['model']}" in text


def test_stages_log_previews_residuals_and_heldout_validation(tiny_cfg, run_dir):
    """The image callback draws each stage's frames (and SinogramFit's residual) from its field;
    SinogramFit's held-out views are scored as Lightning validation."""
    run_job(tiny_cfg("method=nct", "heldout.check_every=2", "export.gif=false", "export.tiff=false",
                     "export.png=false"), run_dir)
    init, fit = (EventAccumulator(str(run_dir / "tb" / name)) for name in ("init", "fit"))
    init.Reload(), fit.Reload()
    assert set(init.Tags()["images"]) == {"init/frames"}
    assert set(fit.Tags()["images"]) == {"fit/frames", "fit/sinogram_residual"}
    held = fit.Scalars("val/heldout_loss")
    # After steps 2 and 4 of 5; Lightning files them under the last training step's 0-based index.
    assert [s.step for s in held] == [1, 3] and all(0 < s.value < 2 for s in held)


def test_capacity_text_says_which_temporal_band_was_kept_and_why(tmp_path):
    band = {"f_max": [0.3, 0.5], "heldout_loss": [0.1, 0.03], "gain": 0.6, "kept_f_max": 0.5,
            "reason": "F_max 0.5 changed the held-out loss by -70.0% (0.1 -> 0.03)"}
    write_capacity(tmp_path, {"family": "siren", "n_terms": 32, "n_params": 21249, "f_max": 0.5, "band": band})
    acc = EventAccumulator(str(tmp_path))
    acc.Reload()
    text = acc.Tensors("capacity/text_summary")[0].tensor_proto.string_val[0].decode()
    assert "siren field, 32 temporal terms, 21249 parameters, F_max 0.5 cycles/rotation" in text
    assert f"temporal band: {band['reason']}" in text
