"""Shared fixtures: the real Hydra config, composed in-process and shrunk to tiny sizes."""

from __future__ import annotations

from pathlib import Path

import pytest
import torch
from hydra import compose, initialize_config_module
from hydra.core.global_hydra import GlobalHydra
from omegaconf import DictConfig

from nct.cli.main import CONFIG_MODULE

TINY = [
    "image.size=32",
    "image.frames_per_rotation=6",
    "scanner.views_per_rotation=60",
    "scanner.n_bins=32",
    "optim.init_steps=5",
    "optim.fit_steps=5",
    "optim.refine=false",
    "export.strip_frames=3",
]


def compose_config(overrides: list[str], with_hydra: bool = False) -> DictConfig:
    """The primary config with ``overrides``, as ``nct`` composes it from the package's configs
    (with its ``hydra`` node when ``with_hydra``)."""
    GlobalHydra.instance().clear()
    try:
        with initialize_config_module(config_module=CONFIG_MODULE, version_base="1.3"):
            return compose(config_name="config", overrides=overrides, return_hydra_config=with_hydra)
    finally:
        GlobalHydra.instance().clear()


@pytest.fixture(autouse=True, scope="session")
def one_thread() -> None:
    """One torch thread for the whole suite: a fit's numbers depend on the thread count, and
    in-process CLI runs would otherwise change it from one test to the next."""
    torch.set_num_threads(1)


DEVICES = ["cpu"] + (["cuda"] if torch.cuda.is_available() else [])


@pytest.fixture(params=DEVICES)
def device(request) -> torch.device:
    """Each device this machine has: a test taking it runs on the CPU and, where there is one, on a CUDA GPU."""
    return torch.device(request.param)


@pytest.fixture
def tiny_cfg():
    """A factory: tiny config with extra overrides."""
    return lambda *extra: compose_config(TINY + list(extra))


@pytest.fixture
def run_dir(tmp_path: Path) -> Path:
    return tmp_path / "run"
