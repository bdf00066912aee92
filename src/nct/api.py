"""nct from Python: the measured data as a `Scan`, `reconstruct` it, and the `Reconstruction` it gives.

    import nct
    scan = nct.Scan.from_file("scan.npz")          # or nct.Scan(sinogram, angles, times, bin_spacing=...)
    rec = nct.reconstruct(scan, n_objects=2, seed=0, optim={"fit_steps": 500})
    rec.frames, rec.masks, rec.background, rec.times, rec.selection, rec.warnings
    rec.metrics()                                   # against the scan's truth, when it has one
    frames, sdf = rec.render(times, size=256)      # the fitted field at any times and size
    rec.save("out"); rec = nct.load("out")

The settings are the ``nct`` command's, validated alike (`nct.run.config.validate`), and the command
runs through the same function (`nct.run.reconstruct.reconstruct_scan`): the same file and settings
give the same frames, bit for bit. docs/API.md says more; docs/examples/ holds a worked example.
"""

from __future__ import annotations

import difflib
from collections.abc import Mapping, Sequence
from numbers import Integral
from pathlib import Path

from hydra import compose as hydra_compose
from hydra import initialize_config_module
from hydra.core.global_hydra import GlobalHydra
from hydra.errors import HydraException
from hydra.initialize import get_gh_backup, restore_gh_from_backup
from omegaconf import DictConfig, OmegaConf
from omegaconf.errors import ConfigAttributeError, ConfigKeyError, OmegaConfBaseException

from nct.acquisition.scan import Scan
from nct.acquisition.sinogram import Truth
from nct.errors import InputError
from nct.run.config import validate
from nct.run.reconstruct import reconstruct_scan
from nct.run.reconstruction import Reconstruction, load_reconstruction
from nct.run.schema import CONFIG_MODULE, NCTConf, register_configs
from nct.run.suggest import describe, unknown_key

__all__ = ["NCTConf", "Reconstruction", "Scan", "Truth", "compose", "load", "reconstruct"]

#: The config groups `reconstruct` takes as settings (what the method reads), and its top-level keys.
GROUPS = ("fbp", "model", "motion", "background", "loss", "optim", "render", "init", "heldout", "trainer",
          "callbacks", "suspect")
KEYS = ("method", "threads")
#: Settings of a run that a Scan or an argument of `reconstruct` holds instead, and where.
ELSEWHERE = {
    "image": "the output grid and frame times are the Scan's: nct.Scan(..., size=, extent=, frames_per_rotation=)",
    "data": "the data are the Scan; K is reconstruct(..., n_objects=)",
    "scanner": "the data are the Scan", "phantom": "the data are the Scan",
    "seed": "seed is an argument of its own: reconstruct(..., seed=)",
}


def compose(overrides: Sequence[str] = ()) -> NCTConf:
    """The ``nct`` command's config with ``overrides`` (``"optim=fast"``, ``"optim.fit_steps=500"``, ...),
    composed by Hydra from the package's configs and validated as the command validates it; for
    `reconstruct`'s ``config``. Bad overrides: `InputError` in one line naming them."""
    return validate(_composed(list(overrides)))


def _composed(overrides: list[str]) -> DictConfig:
    """Hydra's composition of the primary config with ``overrides``, any Hydra state of the caller kept."""
    register_configs()
    backup = get_gh_backup()
    GlobalHydra.instance().clear()
    try:
        with initialize_config_module(config_module=CONFIG_MODULE, version_base="1.3"):
            return hydra_compose(config_name="config", overrides=overrides)
    except (HydraException, OmegaConfBaseException) as err:
        raise InputError(f"overrides {overrides}: {str(err).strip().splitlines()[0]}") from None
    finally:
        restore_gh_from_backup(backup)


def reconstruct(scan: Scan, *, n_objects: int | str | None = None, background: str | Mapping | None = None,
                motion: str | Mapping | None = None, seed: int | None = None, config: NCTConf | None = None,
                **settings: str | Mapping | object) -> Reconstruction:
    """FBP and NeuralCT frames of ``scan`` (an `nct.Scan`), with the truth-free warnings, as ``nct`` gives them.

    ``n_objects``: K, the objects of distinct intensity (None: ``config``'s, by default chosen from the data,
    ``data.n_objects=auto``); ``background``, ``motion``: an option of the group (``"none"``, ``"image"``,
    ``"auto"``; ``"free"``, ``"rigid"``, ``"auto"``, ...); ``seed``: every random stream's (None: ``config``'s,
    0 by default); ``config``: a composed `NCTConf` (`compose`) to start from (None: the defaults).
    ``settings``: one keyword per config group of the method (``fbp``, ``model``, ``motion``, ``background``,
    ``loss``, ``optim``, ``render``, ``init``, ``heldout``, ``trainer``, ``callbacks``, ``suspect``), a string
    picking one of its options (``optim="fast"``, as ``optim=fast``) or a dict of its keys
    (``optim={"fit_steps": 500}``, as ``optim.fit_steps=500``), and ``method`` ("nct" or "fbp") and ``threads``
    (torch's threads);
    options are picked first, then keys set, then all validated as the command validates its overrides.
    The grid and frame times are the scan's. Bad settings: `InputError` in one line naming the key.
    """
    if not isinstance(scan, Scan):
        raise InputError(f"scan: expected an nct.Scan (nct.Scan(...) or nct.Scan.from_file(...)), "
                         f"got {type(scan).__name__}")
    groups = {name: value for name, value in (("background", background), ("motion", motion)) if value is not None}
    conf = configure(config, {**settings, **groups},
                     {"seed": seed, "data": None if n_objects is None else {"n_objects": _objects(n_objects)}})
    return reconstruct_scan(scan, conf)


def _objects(n_objects: int | str) -> int | str:
    """K as the config takes it: a whole number >= 1 or "auto"; `InputError` naming ``n_objects`` otherwise."""
    if n_objects == "auto" or (isinstance(n_objects, Integral) and not isinstance(n_objects, bool) and n_objects >= 1):
        return n_objects if n_objects == "auto" else int(n_objects)
    raise InputError(f"n_objects must be a whole number >= 1, or 'auto' / None (chosen from the data), "
                     f"got {n_objects!r}")


def configure(config: NCTConf | None, settings: Mapping[str, object], fixed: Mapping[str, object]) -> NCTConf:
    """``config`` (None: the defaults) with the options ``settings`` pick, then their keys and ``fixed``'s
    (a None value: left as it is) set, validated (`validate`); `InputError` naming a bad key."""
    if config is not None and not isinstance(config, NCTConf):
        raise InputError(f"config: expected an NCTConf (nct.compose([...])), got {type(config).__name__}")
    picks, values = _split(settings)
    values |= {key: value for key, value in fixed.items() if value is not None}
    if config is None:
        cfg = _composed([f"{group}={option}" for group, option in picks.items()])
    else:
        cfg = OmegaConf.structured(config)
        picked = _composed([f"{group}={option}" for group, option in picks.items()]) if picks else cfg
        for group in picks:
            cfg[group] = picked[group]
    try:
        cfg = OmegaConf.merge(cfg, OmegaConf.create(values))
    except (ConfigKeyError, ConfigAttributeError) as err:
        raise InputError(unknown_key(err.full_key, err.object_type)) from None
    except OmegaConfBaseException as err:
        raise InputError(describe(err)) from None
    return validate(cfg)


def _split(settings: Mapping[str, object]) -> tuple[dict[str, str], dict[str, object]]:
    """The groups' options ``settings`` pick ({group: option}) and the keys they set ({group: {key: value}},
    {key: value})."""
    picks: dict[str, str] = {}
    values: dict[str, object] = {}
    for key, value in settings.items():
        if key in GROUPS and isinstance(value, str):
            picks[key] = value
        elif key in GROUPS and isinstance(value, Mapping):
            values[key] = dict(value)
        elif key in GROUPS:
            raise InputError(f"{key}: expected an option of the group (a str) or a dict of its keys, "
                             f"got {type(value).__name__}")
        elif key in KEYS:
            values[key] = value
        elif key in ELSEWHERE:
            raise InputError(f"{key}: not a setting of nct.reconstruct: {ELSEWHERE[key]}")
        else:
            close = difflib.get_close_matches(key, GROUPS + KEYS, n=1)
            hint = f"did you mean {close[0]}?" if close else f"its settings: {', '.join(GROUPS + KEYS)}"
            raise InputError(f"{key}: not a setting of nct.reconstruct; {hint}")
    return picks, values


def load(folder: str | Path) -> Reconstruction:
    """The reconstruction `Reconstruction.save` or an ``nct`` run wrote into ``folder``: the same arrays and
    records, and its fitted field, ready to ``render``."""
    return load_reconstruction(folder)
