"""TensorBoard records of a finished run: image grids of the frames and the HParams session."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from omegaconf import DictConfig, OmegaConf
from torch.utils.tensorboard import SummaryWriter
from torch.utils.tensorboard.summary import hparams


def flat_hparams(cfg: DictConfig) -> dict[str, float | int | str | bool]:
    """The config as flat ``a.b.c`` scalars (lists and nulls as strings), for the HParams tab."""
    flat: dict[str, float | int | str | bool] = {}

    def walk(node, prefix: str) -> None:
        if isinstance(node, dict):
            for k, v in node.items():
                walk(v, f"{prefix}{k}.")
        elif isinstance(node, (bool, int, float, str)):
            flat[prefix[:-1]] = node
        else:
            flat[prefix[:-1]] = str(node)

    walk(OmegaConf.to_container(cfg, resolve=True), "")
    return flat


def write_run_summary(tb_dir: Path, hparam_values: dict, final: dict[str, float],
                      frames: dict[str, np.ndarray], n_images: int = 6) -> None:
    """Write the HParams session (swept values + final metrics) and a truth|FBP|NCT image per frame.

    frames: name -> [F,H,W]; images are scaled to [0, 1] by the truth's (or first method's) range.
    """
    tb_dir.mkdir(parents=True, exist_ok=True)
    metrics = {k: (v if v is not None and math.isfinite(v) else float("nan")) for k, v in final.items()}
    with SummaryWriter(log_dir=str(tb_dir)) as w:
        exp, ssi, sei = hparams(hparam_values, metrics)
        for summary in (exp, ssi, sei):
            w.file_writer.add_summary(summary)
        for k, v in metrics.items():
            w.add_scalar(k, v)
        ref = frames.get("truth", next(iter(frames.values())))
        vmax = float(max(ref.max(), 1e-6))
        n = next(iter(frames.values())).shape[0]
        for i in np.unique(np.linspace(0, n - 1, min(n_images, n)).round().astype(int)):
            row = np.concatenate([np.clip(f[i] / vmax, 0, 1) for f in frames.values()], axis=1)
            w.add_image("frames/" + "|".join(frames), row, global_step=int(i), dataformats="HW")


def write_capacity(tb_dir: Path, capacity: dict) -> None:
    """The model's capacity as text (family, terms, parameters and, if chosen automatically, why)
    and the held-out loss of each fitted rung as ``capacity/heldout_loss`` over the term count."""
    tb_dir.mkdir(parents=True, exist_ok=True)
    lines = [f"{capacity['family']} field, {capacity['n_terms']} temporal terms, {capacity['n_params']} parameters"]
    choice = capacity.get("choice")
    with SummaryWriter(log_dir=str(tb_dir)) as w:
        if choice:
            lines.append(f"chosen automatically: {choice['reason']}")
            lines += ["", "| terms | held-out loss | parameters |", "|---|---|---|"]
            for rung in choice["ladder"]:
                lines.append(f"| {rung['n_terms']} | {rung['heldout_loss']:.5g} | {rung['n_params']} |")
                w.add_scalar("capacity/heldout_loss", rung["heldout_loss"], global_step=rung["n_terms"])
        w.add_text("capacity", "\n".join(lines))
