"""A reconstruction's fitted field as one file: the field's weights and everything that rebuilds and renders it.

``checkpoints/field.pt`` (a run folder, or a folder `nct.Reconstruction.save` wrote) holds the state
dict of the winner's field with what rebuilds it before the weights are loaded (`FieldSpec`: rung, K,
the background's shape, the model's settings, the rotations spanned) and what renders it in the data's
units (the units, the run's own grid, the clock from seconds to rotations, the acquisition's span and the
occupancy settings). It is read with ``weights_only``: plain numbers, strings and tensors only.
"""

from __future__ import annotations

import pickle
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np
import torch

from nct.acquisition.scanner import ImageGrid
from nct.errors import InputError
from nct.fields.base import SpaceTimeField
from nct.fields.build import FieldSpec
from nct.fields.conf import ModelConf
from nct.fit.conf import RenderConf
from nct.fit.problem import Clock
from nct.fit.units import Units

FIELD_FILE = Path("checkpoints") / "field.pt"  # inside a run folder or a saved reconstruction


@dataclass(frozen=True)
class FittedField:
    """A fitted field (on the CPU, method units) and what renders it: ``spec`` rebuilds it, ``units`` map
    the method's units to the data's, ``grid`` is the reconstruction's own (data units), ``clock`` maps
    seconds to rotations since the first view, ``span`` the acquisition's first and last second
    (`acquisition_span`), ``render`` the occupancy settings of the fit and ``lattice`` the side of the lattice
    over the field of view its last stage drew the field on (the image it fitted: that lattice's values
    interpolated bilinearly; fit/stages.FieldStage)."""

    field: SpaceTimeField
    spec: FieldSpec
    units: Units
    grid: ImageGrid
    clock: Clock
    span: tuple[float, float]
    render: RenderConf
    lattice: int


def acquisition_span(times: np.ndarray) -> tuple[float, float]:
    """First and last second of an acquisition with views at ``times`` [V]: each view lasts until
    the next and the last one as long as the median, so a run's frame times (centred in their
    slots of the acquisition) always lie inside."""
    step = float(np.median(np.diff(times))) if len(times) > 1 else 0.0
    return float(times[0]), float(times[-1]) + step


def save_field(path: Path, fitted: FittedField) -> None:
    """Write ``fitted`` to ``path`` (its folder made), readable by `load_field` with ``weights_only``."""
    spec = fitted.spec
    background = None if spec.background_shape is None else list(spec.background_shape)
    path.parent.mkdir(parents=True, exist_ok=True)
    torch.save({"spec": {"model": asdict(spec.model), "rung": spec.rung, "n_objects": spec.n_objects,
                         "rotations": spec.rotations, "background_shape": background},
                "units": asdict(fitted.units), "grid": asdict(fitted.grid), "clock": asdict(fitted.clock),
                "span": list(fitted.span), "render": asdict(fitted.render), "lattice": fitted.lattice,
                "state_dict": fitted.field.state_dict()}, path)


def load_field(path: Path) -> FittedField:
    """The field `save_field` wrote to ``path``, rebuilt and its every tensor restored; `InputError` saying
    why for a file that is missing, unreadable or written by an older nct."""
    if not path.is_file():
        raise InputError(f"{path.parent.parent} holds no checkpoint of its fitted field ({FIELD_FILE}; a run "
                         "of an nct older than the field file has none: rerun it)")
    try:
        saved = torch.load(path, map_location="cpu", weights_only=True)
        spec, state = saved["spec"], saved["state_dict"]
        shape = spec["background_shape"]
        spec = FieldSpec(ModelConf(**spec["model"]), spec["rung"], spec["n_objects"], spec["rotations"],
                         None if shape is None else tuple(shape))
        parts = (Units(**saved["units"]), ImageGrid(**saved["grid"]), Clock(**saved["clock"]),
                 (float(saved["span"][0]), float(saved["span"][1])), RenderConf(**saved["render"]),
                 int(saved["lattice"]))
    except (OSError, RuntimeError, pickle.UnpicklingError, KeyError, TypeError, ValueError) as err:
        raise InputError(f"{path} is not a field file of this nct ({_first_line(err)}): rerun it") from None
    net = spec.build()
    missing = sorted(set(net.state_dict()) - set(state))
    if missing:
        raise InputError(f"{path} was written by an older nct (its checkpoint has no {', '.join(missing)}): rerun it")
    try:
        net.load_state_dict(state)
    except RuntimeError as err:  # tensors this version's field does not hold, or of other shapes
        raise InputError(f"{path} does not fit this nct's field ({_first_line(err)}): rerun it") from None
    net.eval()
    return FittedField(net, spec, *parts)


def _first_line(err: BaseException) -> str:
    lines = str(err).strip().splitlines()
    return f"{type(err).__name__}: {lines[0] if lines else ''}"
