"""The typed config: every group composes, and bad values fail at start naming the key."""

import subprocess
import sys
from dataclasses import replace
from importlib.resources import files
from pathlib import Path

import pytest
import yaml
from hydra.errors import ConfigCompositionException
from omegaconf.errors import ConfigKeyError, ValidationError

import nct
from nct.errors import InputError
from nct.fit.conf import CallbacksConf, HeldoutConf, OptimConf, RenderConf, TrainerArgs
from nct.init.conf import InitConf
from nct.run.config import validate
from nct.run.schema import NCTConf
from tests.conftest import compose_config


@pytest.mark.parametrize("experiment, phantom", [("circle", "circle"), ("heart", "heart"), ("heart_cine", "heart"),
                                                 ("letters", "letters"), ("static", "static"),
                                                 ("thorax", "composed"), ("nodule", "composed")])
def test_every_experiment_composes_and_validates(experiment, phantom):
    conf = validate(compose_config([f"experiment={experiment}"]))
    assert isinstance(conf, NCTConf)
    assert conf.phantom.name == phantom


def test_defaults_are_the_documented_ones():
    conf = validate(compose_config([]))
    assert (conf.scanner.views_per_rotation, conf.scanner.n_bins) == (720, 128)
    assert conf.phantom.displacement_deg == 100.0 and conf.phantom.radius == 0.15
    assert conf.seed == 0 and conf.fbp.window_deg == 180.0


def test_method_groups_keep_the_tuned_defaults():
    conf = validate(compose_config([]))
    assert (conf.optim, conf.render, conf.init, conf.heldout) == (OptimConf(), RenderConf(), InitConf(), HeldoutConf())
    o = conf.optim
    assert (o.init_steps, o.fit_steps, o.refine_init_steps, o.refine_fit_steps) == (300, 1000, 50, 150)
    assert o.coarse_size == 64
    assert (o.lr, o.refine_lr, o.warmup_steps, o.lr_decay, o.lr_decay_every) == (1e-3, 1e-4, 50, 0.65, 100)
    assert (o.batch_views, o.intensity_lr, o.divergence_factor) == (20, 1e-2, 20.0)
    assert not o.refine and o.fit_intensities and o.min_loss == 0.0
    r = conf.render
    assert (r.band_px, r.band_start_px, r.band_anneal, r.mu, r.k_samp) == (1.0, 4.0, 0.6, 50.0, 1)
    assert (conf.init.frames_per_rotation, conf.init.kappa, conf.init.gmm_share, conf.init.starts) == (60, 3, 0.02, 2)
    assert (conf.heldout.every, conf.heldout.run, conf.heldout.check_every) == (10, 1, 100)
    assert conf.trainer == TrainerArgs(name="cpu", accelerator="cpu") and conf.callbacks == CallbacksConf()
    assert (conf.motion.rungs, conf.motion.first_budget, conf.motion.tolerance, conf.motion.band_f_max,
            conf.motion.band_min_rotations, conf.motion.milestone_margin, conf.motion.still_ratio) == (
        ["static", "free"], 0.25, 2 / 3, 0.5, 1.5, 0.05, 1.0)


def test_fast_optim_halves_every_stage_and_its_schedule():
    """optim=fast is the measured half-steps candidate: steps, warm-up and decay interval halved, the rest as the default."""
    default, fast = (validate(compose_config(o)).optim for o in ([], ["optim=fast"]))
    halved = ("init_steps", "fit_steps", "warmup_steps", "lr_decay_every")
    assert all(getattr(fast, k) * 2 == getattr(default, k) for k in halved)
    assert replace(fast, **{k: getattr(default, k) for k in halved}) == default


def test_groups_switch():
    conf = validate(compose_config(["phantom=composed", "logger=csv", "trainer=gpu", "fbp.filter=hann"]))
    assert conf.phantom.name == "composed" and len(conf.phantom.objects) == 2
    assert conf.logger.name == "csv" and conf.trainer.accelerator == "gpu"


@pytest.mark.parametrize(
    "override, error, words",
    [
        ("phantom.displacement_deg=abc", ValidationError, "phantom.displacement_deg"),
        ("scanner.views_per_rotation=many", ValidationError, "scanner.views_per_rotation"),
        ("phantom.colour=1", ConfigKeyError, "colour"),
        ("phantom=unknown", ConfigCompositionException, "phantom/unknown"),
    ],
)
def test_composition_errors_name_the_key(override, error, words):
    with pytest.raises(Exception) as info:
        compose_config([override])
    text = str(info.value) + str(getattr(info.value, "__cause__", ""))
    assert words in text


@pytest.mark.parametrize(
    "override, key",
    [
        ("scanner.views_per_rotation=-5", "scanner.views_per_rotation"),
        ("phantom.displacement_deg=400", "phantom.displacement_deg"),
        ("phantom.radius=0.4", "phantom.radius"),
        ("image.size=1", "ImageGrid.size"),
        ("fbp.filter=box", "fbp.filter"),
        ("fbp.window_deg=0", "fbp.window_deg"),
        ("data.noise_i0=-1", "data.noise_i0"),
        ("data=file data.path=x.npz data.i0=0", "data.i0"),
        ("loss.data_term=l2", "loss.data_term must be one of l1, poisson"),
        ("seed=-1", "seed"),
        ("data=file", "data.path"),
        ("model.n_terms=-1", "model.n_terms"),
        ("model=grid model.levels=9", "model.resolution must be >= 2**model.levels"),
        ("motion.rungs=[free,wobbly]", "motion.rungs must be a non-empty list of static, rigid, affine, free"),
        ("motion.tolerance=-1", "motion.tolerance"),
        ("motion.milestone_margin=-0.1", "motion.milestone_margin must be >= 0"),
        ("motion.fbp_ratio=-1", "motion.fbp_ratio must be >= 0"),
        ("motion.still_ratio=-1", "motion.still_ratio must be >= 0"),
        ("motion=auto heldout.every=1", "heldout.every must be >= 2"),
        ("heldout.every=0", "compared on held-out views: heldout.every must be >= 2 (or one rung, e.g. motion=free)"),
        ("optim.lr=0", "optim.lr must be > 0"),
        ("optim.lr_decay=1.5", "optim.lr_decay must be in (0, 1]"),
        ("render.mu=1", "render.mu must be > 2"),
        ("render.band_px=5", "render.band_start_px must be >= render.band_px"),
        ("init.gmm_share=0", "init.gmm_share must be in (0, 1]"),
        ("init.frames_per_rotation=0", "init.frames_per_rotation must be >= 1"),
        ("init.starts=0", "init.starts must be >= 1"),
        ("heldout.every=-1", "heldout.every must be >= 0"),
        ("heldout.run=0", "heldout.run must be >= 1"),
        ("trainer.devices=0", "trainer.devices must be >= 1"),
        ("callbacks.snapshot_every_n_steps=-1", "callbacks.snapshot_every_n_steps must be >= 0"),
        ("callbacks.progress_every_s=-1", "callbacks.progress_every_s must be >= 0"),
        ("+phantom.displacment_deg=50", "did you mean phantom.displacement_deg?"),
        ("+seeds=1", "unknown key seeds: not a setting of the config; did you mean seed?"),
        ("phantom=composed +phantom.objects.0.angle=1", "unknown key phantom.objects[0].angle"),
    ],
)
def test_range_errors_name_the_key(override, key):
    with pytest.raises(InputError) as info:
        validate(compose_config(override.split()))
    assert key in str(info.value)


def test_data_n_objects_from_the_command_line(tmp_path):
    assert validate(compose_config(["data.n_objects=3"])).data.n_objects == 3
    assert validate(compose_config([])).data.n_objects == "auto" and validate(compose_config([])).background.name == "auto"
    with pytest.raises(InputError, match="data.n_objects"):
        validate(compose_config(["data.n_objects=zero"]))


def test_default_run_is_the_circle_experiment():
    assert validate(compose_config([])) == validate(compose_config(["experiment=circle"]))


def test_configs_ship_inside_the_package_and_are_found_from_any_folder(tmp_path):
    conf_dir = Path(str(files("nct.conf")))
    assert conf_dir == Path(nct.__file__).parent / "conf" and (conf_dir / "config.yaml").is_file()
    assert not [p for p in conf_dir.rglob("*") if p.is_symlink()]
    done = subprocess.run([sys.executable, "-m", "nct.cli.main", "--cfg", "hydra"], cwd=tmp_path, capture_output=True,
                          text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    sources = yaml.safe_load(done.stdout)["hydra"]["runtime"]["config_sources"]
    assert {"path": "nct.conf", "schema": "pkg", "provider": "main"} in sources


def test_config_schemas_and_the_job_record_import_without_torch():
    """So that bad input ends ``nct`` before torch is loaded (nct.run.job validates, then imports the pipeline),
    and before matplotlib and scipy's image modules (the letters phantom's glyphs load them when drawn)."""
    heavy = ("torch", "lightning", "matplotlib", "scipy.ndimage")
    code = f"import sys, nct.run.job, nct.cli.main; print(sorted(m for m in {heavy} if m in sys.modules))"
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "[]"
