"""The did-you-mean of a config key no schema declares: every undeclared key of a composed config
(``+key`` included, which Hydra lets through) and one line for it naming the nearest key, the option of
its group or the other group that has it, or the config group it resembles; OmegaConf's errors in one line."""

from __future__ import annotations

import difflib
from collections.abc import Iterator
from dataclasses import fields, is_dataclass
from importlib import resources

from omegaconf import DictConfig, ListConfig, OmegaConf
from omegaconf.errors import OmegaConfBaseException

from nct.run.schema import CONFIG_MODULE, SCHEMAS


def undeclared_keys(node: DictConfig, prefix: str = "") -> Iterator[tuple[str, type]]:
    """(full key, schema) of every key of ``node`` and its children that its node's schema lacks."""
    schema = OmegaConf.get_type(node)
    declared = {f.name for f in fields(schema)} if is_dataclass(schema) else None
    for key, child in node.items_ex(resolve=False):
        full = f"{prefix}{key}"
        if declared is not None and key not in declared:
            yield full, schema
        elif isinstance(child, DictConfig):
            yield from undeclared_keys(child, full + ".")
        elif isinstance(child, ListConfig):
            for i, item in enumerate(child):
                if isinstance(item, DictConfig):
                    yield from undeclared_keys(item, f"{full}[{i}].")


def unknown_key(full_key: str, schema: type) -> str:
    """One line for a key that ``schema`` (a dataclass) does not declare, with a did-you-mean: the option
    of its group that has the key (``data.path`` -> ``data=file``), else the one other group that has it
    (``trainer.snapshot_every_n_steps`` -> ``callbacks.snapshot_every_n_steps``), else the nearest of its
    keys and, at the top level, of the config groups (``expriment`` -> the group ``experiment``, not the
    key ``export``)."""
    parent, _, key = full_key.rpartition(".")
    known = [f.name for f in fields(schema)]
    where = f"{parent} ({schema.__name__})" if parent else "the config"
    owners = [name for name, node in SCHEMAS.get(parent, {}).items() if key in {f.name for f in fields(node)}]
    elsewhere = [group for group, options in SCHEMAS.items() if group != parent and parent in SCHEMAS
                 and any(key in {f.name for f in fields(node)} for node in options.values())]
    groups = {} if parent else {group: options for group, options in config_groups().items() if group not in known}
    close = difflib.get_close_matches(key, known + list(groups), n=1)
    if owners:
        hint = f"it is a setting of {parent}={owners[0]}: did you mean {parent}={owners[0]}?"
    elif len(elsewhere) == 1:
        hint = f"it is a setting of the config group {elsewhere[0]}: did you mean {elsewhere[0]}.{key}?"
    elif close and close[0] in groups:
        hint = f"did you mean the config group {close[0]} ({close[0]}=<option>: {', '.join(groups[close[0]])})?"
    else:
        hint = f"did you mean {parent + '.' if parent else ''}{close[0]}?" if close else f"its keys: {', '.join(known)}"
    return f"unknown key {full_key}: not a setting of {where}; {hint}"


def config_groups() -> dict[str, list[str]]:
    """The config groups a user picks an option of (``group=option``, as ``nct --help`` lists them) and
    their options: the package's config folders, Hydra's own aside."""
    root = resources.files(CONFIG_MODULE)
    return {folder.name: sorted(f.name.removesuffix(".yaml") for f in folder.iterdir() if f.name.endswith(".yaml"))
            for folder in sorted(root.iterdir(), key=lambda f: f.name)
            if folder.is_dir() and folder.name != "hydra" and any(f.name.endswith(".yaml") for f in folder.iterdir())}


def describe(err: OmegaConfBaseException) -> str:
    """An OmegaConf error in one line, with the full key when its message lacks it."""
    return str(err).splitlines()[0] + _key_suffix(err)


def _key_suffix(err: OmegaConfBaseException) -> str:
    key = getattr(err, "full_key", None)
    return f" (key: {key})" if key and f"{key} " not in str(err).splitlines()[0] + " " else ""
