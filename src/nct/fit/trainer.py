"""Running one optimisation stage in its own Lightning Trainer: the index data it is served, its
callbacks (``callbacks.py``; here the snapshots of the run's Dice-against-time curve), its logger,
checkpoint and resume.
"""

from __future__ import annotations

import json
import logging
import time
import warnings
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

import lightning as L
import numpy as np
import torch
from lightning.pytorch.callbacks import Callback, LearningRateMonitor
from lightning.pytorch.loggers import CSVLogger, TensorBoardLogger
from lightning.pytorch.utilities.warnings import PossibleUserWarning
from torch import Tensor
from torch.utils.data import DataLoader, IterableDataset

from nct.errors import InputError
from nct.fit.callbacks import DivergenceCheck, ImageLog
from nct.fit.conf import LOGGERS, TrainerConf
from nct.fit.progress import StageBar, StageLog, log_stage, show_bar
from nct.fit.stages import FieldStage
from nct.records import write_json

log = logging.getLogger(__name__)
RECORD = "stage.json"  # beside a stage's checkpoint: its steps, losses and wall time, written when it finished


class IndexBatches(IterableDataset):
    """``steps`` random minibatches of ``batch`` indices drawn without replacement from ``pool``."""

    def __init__(self, pool: np.ndarray, batch: int, steps: int, seed: int) -> None:
        self.pool, self.batch, self.steps, self.seed = pool, min(batch, len(pool)), steps, seed

    def __len__(self) -> int:
        return self.steps

    def __iter__(self) -> Iterator[Tensor]:
        rng = np.random.default_rng(self.seed)
        for _ in range(self.steps):
            yield torch.from_numpy(rng.choice(self.pool, size=self.batch, replace=False))


class IndexDataModule(L.LightningDataModule):
    """Serves ``IndexBatches``: the timepoints (views or SDF frames) of each step; and the
    held-out views ``held`` in chunks for validation (none: no validation)."""

    def __init__(self, pool: np.ndarray, batch: int, steps: int, seed: int, held: np.ndarray | None = None,
                 chunk: int = 64) -> None:
        super().__init__()
        self.batches = IndexBatches(pool, batch, steps, seed)
        self.held = [torch.from_numpy(part) for part in np.array_split(held, -(-len(held) // chunk))] \
            if held is not None and len(held) else []

    def train_dataloader(self) -> DataLoader:
        return DataLoader(self.batches, batch_size=None)

    def val_dataloader(self) -> DataLoader:
        return DataLoader(self.held, batch_size=None)


class RunClock:
    """Seconds since a run began, less the time spent taking snapshots (``SnapshotLog``)."""

    def __init__(self) -> None:
        self.start, self.paused = time.perf_counter(), 0.0

    def seconds(self) -> float:
        return time.perf_counter() - self.start - self.paused


@dataclass(frozen=True)
class Snapshot:
    """The field's weights after ``step`` steps of ``stage`` (its module), ``seconds`` into the run."""

    name: str
    step: int
    seconds: float
    stage: FieldStage
    state: dict[str, Tensor]


def snapshot(name: str, step: int, stage: FieldStage, clock: RunClock) -> Snapshot:
    """A copy of ``stage``'s field now; the copying's time is left out of ``clock``."""
    start = time.perf_counter()
    state = {k: v.detach().clone() for k, v in stage.field.state_dict().items()}
    taken = Snapshot(name, step, clock.seconds(), stage, state)
    clock.paused += time.perf_counter() - start
    return taken


class SnapshotLog(Callback):
    """Copy the stage's field into ``into`` before its first step, every ``every`` steps and after
    its last: the points of a run's Dice-against-time curve, scored once the run is over (no stage
    sees the truth). The copies' own time is left out of ``clock``."""

    def __init__(self, name: str, every: int, into: list[Snapshot], clock: RunClock) -> None:
        self.name, self.every, self.into, self.clock = name, every, into, clock

    def take(self, trainer, pl_module: FieldStage) -> None:
        self.into.append(snapshot(self.name, int(trainer.global_step), pl_module, self.clock))

    def on_train_start(self, trainer, pl_module) -> None:
        self.take(trainer, pl_module)

    def on_train_batch_end(self, trainer, pl_module, outputs, batch, batch_idx) -> None:
        if trainer.global_step % self.every == 0:
            self.take(trainer, pl_module)

    def on_train_end(self, trainer, pl_module) -> None:
        if self.into[-1].step != trainer.global_step:
            self.take(trainer, pl_module)


def check_accelerator(accelerator: str) -> None:
    """Refuse a GPU accelerator that torch cannot use, naming the fix (Lightning would fail deep inside)."""
    if accelerator in ("gpu", "cuda") and not (torch.cuda.is_available() or torch.backends.mps.is_available()):
        build = "a CPU-only build" if torch.version.cuda is None else "a CUDA build but sees no GPU"
        raise InputError(f"trainer.accelerator={accelerator}: torch {torch.__version__} is {build}; install a CUDA "
                         "build of torch (https://pytorch.org/get-started/locally/) on a machine with an NVIDIA GPU, "
                         "or use trainer=cpu")


@contextmanager
def quiet_lightning() -> Iterator[None]:
    """Silence Lightning's per-Trainer banners (accelerator, tips, "max_steps reached"), the warning
    about our sized iterable dataset, which has no workers to confuse, and its "possible mistakes"
    (data workers, "GPU available but not used": the run's accelerator is ``trainer=``'s choice)."""
    lightning_log = logging.getLogger("lightning.pytorch")
    level = lightning_log.level
    lightning_log.setLevel(logging.WARNING)
    try:
        with warnings.catch_warnings():
            warnings.filterwarnings("ignore", message=".*IterableDataset.*__len__.*")
            warnings.filterwarnings("ignore", message=".*LeafSpec.*")
            warnings.filterwarnings("ignore", category=PossibleUserWarning)
            yield
    finally:
        lightning_log.setLevel(level)


def run_stage(module: FieldStage, data: IndexDataModule, steps: int, name: str, conf: TrainerConf,
              log_dir: Path | None, logger: str, extra_callbacks: tuple[Callback, ...] = (),
              check_every: int = 0, resume: bool = False) -> dict:
    """Fit ``module`` for ``steps`` in a fresh Trainer with its own logger version and checkpoint
    folder (``log_dir/tb/<name>``, ``log_dir/checkpoints/<name>``); return steps, losses, wall time.
    ``conf``: Lightning's arguments and the callbacks' settings; the divergence limit is the module's
    ``optim.divergence_factor``.
    With held-out views in ``data`` and ``check_every`` > 0, Lightning validates every
    ``check_every`` steps (``val/heldout_loss``). ``resume``: a stage that finished before in
    ``log_dir`` is not run again; its checkpoint is loaded and its record returned (each stage
    starts a fresh optimiser, so this continues a killed run exactly)."""
    if logger not in LOGGERS:
        raise ValueError(f"logger must be one of {LOGGERS}, got {logger!r}")
    check_accelerator(conf.args.accelerator)
    start = time.perf_counter()
    if steps == 0:
        return {"steps": 0, "losses": {}, "wall_time_s": 0.0}
    folder = Path(log_dir) / "checkpoints" / name if log_dir is not None else None
    record = finished_record(folder) if resume and folder is not None else None
    if record is not None:
        return load_stage(module, folder, name, record)
    every = check_every if data.held else 0
    bar = show_bar(conf.callbacks.progress_bar)
    stage_logger, callbacks = stage_logging(module, name, conf, log_dir, logger, extra_callbacks, bar)
    with quiet_lightning():
        trainer = L.Trainer(
            accelerator=conf.args.accelerator, devices=conf.args.devices, max_steps=steps, max_epochs=1,
            logger=stage_logger, callbacks=callbacks, enable_checkpointing=False,
            enable_progress_bar=bar, enable_model_summary=False,
            log_every_n_steps=min(conf.args.log_every_n_steps, steps), num_sanity_val_steps=0,
            **validation(steps, every),
        )
        trainer.fit(module, train_dataloaders=data.train_dataloader(),
                    val_dataloaders=data.val_dataloader() if every else None)
        if folder is not None:
            trainer.save_checkpoint(folder / "last.ckpt")
    result = stage_record(trainer, module, steps, start)
    if folder is not None:
        write_json(folder / RECORD, result)  # written last (and whole): the stage counts as finished
    if not bar:
        log_stage(name, result)
    return result


def finished_record(folder: Path) -> dict | None:
    """The record of the stage that finished in ``folder``; None where none did, or where a kill cut the record
    short (nct before records were written whole): the stage then runs again."""
    try:
        return json.loads((folder / RECORD).read_text())
    except (OSError, ValueError):
        return None


def load_stage(module: FieldStage, folder: Path, name: str, record: dict) -> dict:
    """A finished stage ``name`` resumed: ``module`` loaded from its checkpoint in ``folder`` (`InputError`
    where it does not fit this version's model), its held-out history and ``record`` as it ran."""
    weights = torch.load(folder / "last.ckpt", map_location=module.device, weights_only=True)["state_dict"]
    try:
        module.load_state_dict(weights)
    except RuntimeError as err:
        detail = str(err).splitlines()[1].strip() if len(str(err).splitlines()) > 1 else str(err)
        raise InputError(f"resume: the checkpoint of stage {name} in {folder} does not fit this version's model "
                         f"({detail}); rerun it in a new folder") from None
    log.info("resume: stage %s loaded from %s", name, folder)
    module.heldout_history = [(int(step), float(loss)) for step, loss in record.get("heldout_history", [])]
    return record | {"resumed": True}


def stage_logging(module: FieldStage, name: str, conf: TrainerConf, log_dir: Path | None, logger: str,
                  extra_callbacks: tuple[Callback, ...], bar: bool
                  ) -> tuple[TensorBoardLogger | CSVLogger | bool, list[Callback]]:
    """Stage ``name``'s logger (False: none) and callbacks, in the order Lightning calls them: the
    divergence check, ``extra_callbacks``, the progress bar (``bar``) or lines, then the learning
    rate and (TensorBoard) the images."""
    callbacks: list[Callback] = [DivergenceCheck(name, module.optim.divergence_factor), *extra_callbacks]
    callbacks.append(StageBar(name) if bar else StageLog(name, conf.callbacks.progress_every_s))
    stage_logger: TensorBoardLogger | CSVLogger | bool = False
    if log_dir is not None and logger == "tensorboard":
        stage_logger = TensorBoardLogger(str(log_dir), name="tb", version=name, default_hp_metric=False)
        callbacks += [LearningRateMonitor("step"), ImageLog(name, conf.callbacks.image_every_n_steps)]
    elif log_dir is not None and logger == "csv":
        stage_logger = CSVLogger(str(log_dir), name="csv", version=name)
        callbacks.append(LearningRateMonitor("step"))
    return stage_logger, callbacks


def stage_record(trainer: L.Trainer, module: FieldStage, steps: int, start: float) -> dict:
    """What a finished stage's ``stage.json`` holds: its steps (and ``steps`` planned), last losses, wall
    time since ``start`` and held-out history."""
    losses = {k.removeprefix("train/"): float(v) for k, v in trainer.callback_metrics.items()
              if k.startswith(("train/", "val/"))}
    result = {"steps": int(trainer.global_step), "planned_steps": steps, "losses": losses,
              "wall_time_s": time.perf_counter() - start}
    if module.heldout_history:
        result["heldout_history"] = [list(point) for point in module.heldout_history]
    return result


def validation(steps: int, every: int) -> dict:
    """Trainer settings that validate every ``every`` steps (0: never)."""
    if every <= 0:
        return {"limit_val_batches": 0}
    return {"val_check_interval": min(every, steps), "check_val_every_n_epoch": None}
