"""TensorBoard records of a finished run: image grids of the frames and the HParams session.

The HParams session lives in its own folder, ``tb/hparams``, holding nothing but the ``hp/*``
scalars: TensorBoard lists as metrics every scalar of a session's folder and its subfolders, so a
session in ``tb/`` would also list what Lightning logs per stage in ``tb/<stage>`` (``epoch``,
losses, learning rates). No experiment summary is written: TensorBoard then builds the table's
columns from all sessions it sees, the keys that differ between runs first.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np
from hydra.core.override_parser.overrides_parser import OverridesParser
from omegaconf import DictConfig, OmegaConf
from tensorboard.plugins.hparams.summary_v2 import hparams_pb
from torch.utils.tensorboard import SummaryWriter

from nct.run.phases import breakdown, phase_table, stage_walls
from nct.run.tables import fmt, markdown_table

#: Config keys that name a run in the HParams tab whatever its overrides: what was reconstructed, how.
IDENTITY_KEYS = ("method", "data.name", "data.path", "phantom.name", "model.name", "seed")
#: Where `write_hparams` puts the session, below the run's ``tb/``.
HPARAMS_DIR = "hparams"

HParam = bool | int | float | str


def run_hparams(cfg: DictConfig, overrides: Sequence[str]) -> dict[str, HParam]:
    """What the HParams tab shows of a run: `IDENTITY_KEYS` from ``cfg``, then every command-line override.

    Override values keep their type (``trainer.refine=true`` a bool, ``seed=1`` a number); a group
    choice (``model=grid``) is its option's name; lists and nulls are their text. Hydra's own
    overrides (``hydra.*``, ``hydra/launcher=...``) and deletions (``~key``) are left out.
    """
    values: dict[str, HParam] = {}
    for key in IDENTITY_KEYS:
        value = OmegaConf.select(cfg, key, default=None)
        if value is not None:
            values[key] = _scalar(value)
    for override in OverridesParser.create().parse_overrides(list(overrides)):
        key = override.get_key_element().lstrip("+")
        if not key.startswith("hydra") and not override.is_delete():
            values[key] = _scalar(override.value())
    return values


def _scalar(value: object) -> HParam:
    return value if isinstance(value, (bool, int, float, str)) else "null" if value is None else str(value)


def write_hparams(tb_dir: Path, hparam_values: dict[str, HParam], final: dict[str, float | None]) -> Path:
    """The run's HParams session in ``tb_dir/hparams``: ``hparam_values`` and the ``hp/*`` metrics in
    ``final`` (None or non-finite: NaN); returns the session's folder."""
    folder = tb_dir / HPARAMS_DIR
    with SummaryWriter(log_dir=str(folder)) as w:
        w.file_writer.add_summary(hparams_pb(hparam_values))
        for k, v in final.items():
            w.add_scalar(k, v if v is not None and math.isfinite(v) else float("nan"))
    return folder


def write_frames(tb_dir: Path, frames: dict[str, np.ndarray], n_images: int = 6) -> None:
    """A truth|FBP|NCT image per shown frame, ``n_images`` frames spread over time.

    frames: name -> [F,H,W]; images are scaled to [0, 1] by the truth's (or first method's) range.
    """
    with SummaryWriter(log_dir=str(tb_dir)) as w:
        ref = frames.get("truth", next(iter(frames.values())))
        vmax = float(max(ref.max(), 1e-6))
        n = next(iter(frames.values())).shape[0]
        for i in np.unique(np.linspace(0, n - 1, min(n_images, n)).round().astype(int)):
            row = np.concatenate([np.clip(f[i] / vmax, 0, 1) for f in frames.values()], axis=1)
            w.add_image("frames/" + "|".join(frames), row, global_step=int(i), dataformats="HW")


def write_selection(tb_dir: Path, model: dict, selection: dict) -> None:
    """The chosen model and why, as text (``selection``): the winner's rung, family and parameters, the
    tournament's reason and its table (selection.csv), one row per candidate."""
    tb_dir.mkdir(parents=True, exist_ok=True)
    rows = [[r["candidate"], r["rung"], r["steps"], fmt(r["heldout_misfit"], 5), r["verdict"]] for r in selection["table"]]
    lines = [f"{model['motion']} motion, {model['family']} field, {model['n_params']} parameters",
             f"chosen: {selection['reason']}", "",
             markdown_table(["candidate", "rung", "steps", "held-out misfit", "verdict"], rows)]
    with SummaryWriter(log_dir=str(tb_dir)) as w:
        w.add_text("selection", "\n".join(lines))


def write_trace(tb_dir: Path, trace: list[dict]) -> None:
    """The Dice-against-time curve as ``trace/median_dice`` and ``trace/median_mse`` scalars whose
    step is the snapshot's time into the reconstruction in milliseconds (TensorBoard's STEP axis)."""
    with SummaryWriter(log_dir=str(tb_dir)) as w:
        for row in trace:
            ms = round(1000 * row["seconds"])
            w.add_scalar("trace/median_dice", row["median_dice"], global_step=ms)
            w.add_scalar("trace/median_mse", row["median_mse"], global_step=ms)


def write_motion(tb_dir: Path, motion: dict) -> None:
    """metrics.json's ``motion_determinacy`` (`nct.moments.determinacy`) as text, and its spread along the
    rays as the ``motion/ray_spread_px`` scalar."""
    verdict = "determined" if motion["determined"] else "NOT determined: more rotations or a motion prior needed"
    with SummaryWriter(log_dir=str(tb_dir)) as w:
        w.add_text("motion_determinacy", f"motion along the rays {verdict}: spread {fmt(motion['ray_spread_px'])} px "
                   f"between equally good centroid trajectories (threshold {fmt(motion['threshold_px'])} px), prior "
                   f"length scale {fmt(motion['length_scale_rot'])} rotations, misfit {fmt(motion['misfit_px'])} px")
        w.add_scalar("motion/ray_spread_px", motion["ray_spread_px"])


def write_phases(tb_dir: Path, phases: dict, stages: dict) -> None:
    """Where the run's time went (metrics.json ``phases``, `nct.run.phases`): a table as text (``phases``) and
    each phase's wall seconds as a ``phases/<phase>`` scalar, the tournament split into fits and selection."""
    with SummaryWriter(log_dir=str(tb_dir)) as w:
        w.add_text("phases", phase_table(phases, stages))
        for phase, seconds in breakdown(phases["wall_s"], stage_walls(stages)).items():
            w.add_scalar(f"phases/{phase}", seconds)
