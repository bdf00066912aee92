"""The typed config: every group composes, and bad values fail at start naming the key."""

import pytest
from hydra.errors import ConfigCompositionException
from omegaconf.errors import ConfigKeyError, ValidationError

from nct.config import NCTConf, validate
from nct.errors import InputError

from conftest import compose_config


@pytest.mark.parametrize("experiment", ["circle", "heart", "heart_cine", "letters", "static"])
def test_every_experiment_composes_and_validates(experiment):
    conf = validate(compose_config([f"experiment={experiment}"]))
    assert isinstance(conf, NCTConf)
    assert conf.phantom.name == ("heart" if experiment.startswith("heart") else experiment)


def test_defaults_are_the_documented_ones():
    conf = validate(compose_config([]))
    assert (conf.scanner.views_per_rotation, conf.scanner.n_bins) == (720, 128)
    assert conf.phantom.displacement_deg == 100.0 and conf.phantom.radius == 0.15
    assert conf.seed == 0 and conf.fbp.window_deg == 180.0


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
        ("seed=-1", "seed"),
        ("data=file", "data.path"),
        ("model.n_terms=-1", "model.n_terms"),
        ("model=grid model.levels=9", "model.resolution must be >= 2**model.levels"),
        ("capacity.ladder=[8,0]", "capacity.ladder must be strictly increasing"),
        ("capacity.tolerance=2", "capacity.tolerance"),
        ("capacity=auto trainer.heldout_every=1", "trainer.heldout_every must be >= 2"),
    ],
)
def test_range_errors_name_the_key(override, key):
    with pytest.raises(InputError) as info:
        validate(compose_config(override.split()))
    assert key in str(info.value)


def test_default_run_is_the_circle_experiment():
    assert validate(compose_config([])) == validate(compose_config(["experiment=circle"]))
