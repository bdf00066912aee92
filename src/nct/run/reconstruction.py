"""What one reconstruction gives, as a typed value: frames, parts, records, warnings and the fitted field.

`nct.reconstruct` returns a `Reconstruction` and the ``nct`` command writes its run folder from one
(run/pipeline.py). ``save`` writes the files that hold it (those of a run folder: ``sinogram.npz``,
``reconstruction.npz``, ``selection.csv``, ``reconstruction.json`` and the field file
``checkpoints/field.pt``) and `load_reconstruction` reads them back, from a saved folder or a run folder.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from numbers import Integral
from pathlib import Path

import numpy as np

from nct.acquisition.io import load_sinogram, save_sinogram
from nct.acquisition.scan import Scan
from nct.acquisition.scanner import ImageGrid
from nct.acquisition.sinogram import Truth
from nct.errors import InputError
from nct.method.fitted import FIELD_FILE, FittedField, load_field, save_field
from nct.records import write_json
from nct.run.metrics import FrameMetrics, frame_metrics
from nct.run.tables import write_csv
from nct.select.tournament import Row

SINOGRAM, FRAMES, SELECTION, RECORD = "sinogram.npz", "reconstruction.npz", "selection.csv", "reconstruction.json"


@dataclass
class Reconstruction:
    """One reconstruction of ``scan``: ``fbp`` [F, H, W] float32; NeuralCT's ``frames`` [F, H, W] float32
    (the whole image), ``masks`` [F, K, H, W] bool (each object's inside) and ``background`` [H, W]
    float32 (``background=image``; else None), all None for FBP only (``method=fbp``); ``warnings``:
    the truth-free signs of a poor fit or of data that do not fix the motion (status.json's); ``record``:
    what metrics.json records of it, in plain JSON values (frame times, held-out losses, model, selection,
    stages, intensities, init, motion_determinacy, geometry_check); ``fitted``: the winner's field and what
    renders it (None for FBP only); ``trace``: the snapshots' frames (``callbacks.snapshot_every_n_steps``;
    not saved). Frame times and the grid are the scan's (``times`` [F] s, ``extent``).
    """

    scan: Scan
    fbp: np.ndarray
    frames: np.ndarray | None = None
    masks: np.ndarray | None = None
    background: np.ndarray | None = None
    warnings: list[str] = field(default_factory=list)
    record: dict = field(default_factory=dict)
    fitted: FittedField | None = None
    trace: list = field(default_factory=list)

    @property
    def times(self) -> np.ndarray:
        """The frames' times [F], seconds."""
        return self.scan.frame_times

    @property
    def extent(self) -> float:
        """The side of the frames' square field of view, in the data's length unit."""
        return self.scan.grid.extent

    @property
    def selection(self) -> list[Row]:
        """The tournament's table (selection.csv): one typed row per candidate fit; empty for FBP only."""
        return [Row(**row) for row in self.record.get("selection", {}).get("table", [])]

    @property
    def model(self) -> dict:
        """The winner's field: motion rung, family, parameters (metrics.json ``model``)."""
        return self.record.get("model", {})

    @property
    def init(self) -> dict:
        """The winner's start and the method's units (metrics.json ``init``)."""
        return self.record.get("init", {})

    @property
    def stages(self) -> dict:
        """Each fitted stage's steps, losses and time (metrics.json ``stages``)."""
        return self.record.get("stages", {})

    def methods(self) -> dict[str, np.ndarray]:
        """The frames by method: ``fbp``, and ``nct`` unless FBP only."""
        return {"fbp": self.fbp} | ({"nct": self.frames} if self.frames is not None else {})

    def metrics(self, truth: Truth | None = None) -> dict[str, FrameMetrics]:
        """Each method's scores (`nct.run.metrics.FrameMetrics`: MSE, NRMSE, PSNR, SSIM, Dice per frame)
        against ``truth`` (an `nct.Truth` on this grid at these times; None: the scan's)."""
        truth = truth if truth is not None else self.scan.truth
        if truth is None:
            raise InputError("metrics: the scan holds no truth to score against: give one, "
                             "metrics(truth=nct.Truth(...))")
        if np.shape(truth.frames) != self.fbp.shape:
            raise InputError(f"metrics: truth frames of shape {np.shape(truth.frames)}, the reconstruction's "
                             f"{self.fbp.shape} [F, H, W]")
        return {name: frame_metrics(f, truth.frames, truth.level, truth.levels) for name, f in self.methods().items()}

    def render(self, times: np.ndarray, size: int | None = None) -> tuple[np.ndarray, np.ndarray]:
        """The fitted field at ``times`` [T] (s, inside the acquisition) on ``size`` pixels a side (None: the
        reconstruction's) over its field of view: intensity frames [T, S, S] and SDF frames [T, K, S, S]
        (float32, the data's units, positive inside), as ``nct-export`` renders them."""
        from nct.method.reload import check_times, render

        if self.fitted is None:
            raise InputError("render: an FBP-only reconstruction (method=fbp) fitted no field to render")
        size = self.scan.grid.size if size is None else size
        if isinstance(size, bool) or not isinstance(size, Integral) or size < 2:
            raise InputError(f"render: size must be a whole number >= 2, got {size!r}")
        times = np.atleast_1d(np.asarray(times, dtype=np.float64))
        check_times(self.fitted.span, times, "render: times")
        return render(self.fitted, times, int(size))

    def save(self, folder: str | Path) -> Path:
        """Write this reconstruction into ``folder`` (made if missing; one that holds a reconstruction
        already is refused): the files of a run folder that `nct.load` reads back. Returns the folder."""
        folder = Path(folder)
        if (folder / FRAMES).exists():
            raise InputError(f"{folder} holds a reconstruction already ({FRAMES}): save into another folder")
        folder.mkdir(parents=True, exist_ok=True)
        save_sinogram(folder / SINOGRAM, self.scan.sinogram)
        self.write(folder)
        return folder

    def write(self, folder: Path) -> None:
        """The files that hold this reconstruction but its sinogram (a run writes that as it reads its data):
        ``reconstruction.npz``, ``selection.csv``, ``reconstruction.json`` and the field file."""
        parts = {"nct_masks": self.masks, "nct_background": self.background}
        arrays = self.methods() | {name: a for name, a in parts.items() if a is not None}
        np.savez_compressed(folder / FRAMES, times=np.asarray(self.times, dtype=np.float64),
                            extent=np.float64(self.extent), **arrays)
        if "selection" in self.record:
            write_csv(self.record["selection"]["table"], folder / SELECTION)
        if self.fitted is not None:
            save_field(folder / FIELD_FILE, self.fitted)
        scan = {"times_unit": self.scan.times_unit, "simulated": self.scan.simulated}
        write_json(folder / RECORD, {"scan": scan, "warnings": self.warnings, "record": self.record})


def load_reconstruction(folder: str | Path) -> Reconstruction:
    """The reconstruction `Reconstruction.save` (or an ``nct`` run) wrote into ``folder``: equal arrays and
    records, the field rebuilt (``trace`` is not saved); `InputError` saying what is missing."""
    folder = Path(folder)
    missing = [name for name in (RECORD, FRAMES, SINOGRAM) if not (folder / name).is_file()]
    if missing:
        raise InputError(f"{folder} holds no saved reconstruction (no {', '.join(missing)}): a folder "
                         "Reconstruction.save or a finished nct run wrote")
    saved = json.loads((folder / RECORD).read_text())
    with np.load(folder / FRAMES) as npz:
        arrays = {name: npz[name] for name in npz.files}
    grid = ImageGrid(int(arrays["fbp"].shape[-1]), float(arrays["extent"]))
    scan = Scan.of(load_sinogram(folder / SINOGRAM), grid, arrays["times"], **saved["scan"])
    fitted = load_field(folder / FIELD_FILE) if "model" in saved["record"] else None
    return Reconstruction(scan, arrays["fbp"], arrays.get("nct"), arrays.get("nct_masks"), arrays.get("nct_background"),
                          saved["warnings"], saved["record"], fitted)
