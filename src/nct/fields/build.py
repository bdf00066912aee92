"""The motion ladder's fields by name: one config names the class it builds."""

from __future__ import annotations

from dataclasses import dataclass, replace

import torch

from nct.fields.base import SpaceTimeField
from nct.fields.conf import ModelConf
from nct.fields.free import Field, GridField
from nct.fields.moved import POSE, moved_template


def build_field(conf: ModelConf, n_objects: int, generator: torch.Generator, motion: str = "free",
                span: float = 1.0) -> SpaceTimeField:
    """The field of ``conf.family`` holding ``motion`` (a rung of the ladder: static has no temporal
    terms; rigid, affine: a moved template, moved.py; free: the paper's g_E + g_V, a lone object's
    carried along its path) for ``n_objects`` objects on a scan of ``span`` rotations."""
    if n_objects < 1:
        raise ValueError(f"n_objects must be >= 1, got {n_objects}")
    if motion in POSE:
        return moved_template(conf, motion, n_objects, span)
    if motion == "static":
        conf = replace(conf, n_terms=0)
    elif motion != "free":
        raise ValueError(f"motion {motion!r} is not a rung of the ladder")
    return {"siren": Field, "grid": GridField}[conf.family](conf, n_objects, generator, span)


@dataclass(frozen=True)
class FieldSpec:
    """What rebuilds a fitted field before its weights are loaded: `build_field`'s arguments (``model``
    as the field was built, its band's ``f_max`` included; ``rung``; ``n_objects``; ``rotations`` the
    scan spans) and the shape [H, W] of its background image (None: none)."""

    model: ModelConf
    rung: str
    n_objects: int
    rotations: float
    background_shape: tuple[int, int] | None = None

    def build(self) -> SpaceTimeField:
        """A field of this shape, every tensor to be restored from a state dict (the caller's random
        streams untouched)."""
        with torch.random.fork_rng(devices=[]):
            net = build_field(self.model, self.n_objects, torch.Generator(), self.rung, self.rotations)
        if self.background_shape is not None:
            net.set_background(torch.zeros(self.background_shape))
        return net
