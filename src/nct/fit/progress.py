"""What a run shows while it fits: a bar per stage in a terminal; otherwise (a file, a sweep's job)
a log line every few seconds of each stage and one when it ends.

Lightning's TQDM bar sizes itself to the terminal. A terminal that reports a size of 0 x 0 (a
pty whose size nobody set: some IDE consoles and container shells, ``script``) left tqdm no row to
draw on, so only the newline at the bar's end appeared: blank lines. The bar here takes the size
``shutil.get_terminal_size`` gives, which falls back to $COLUMNS/$LINES or 80 x 24.
"""

from __future__ import annotations

import logging
import shutil
import sys
import time
from collections.abc import Callable

from lightning.pytorch.callbacks import Callback, TQDMProgressBar

log = logging.getLogger(__name__)


def show_bar(progress_bar: bool | None) -> bool:
    """The ``callbacks.progress_bar`` setting: on when asked, or (None) when stdout is a terminal."""
    return sys.stdout.isatty() if progress_bar is None else bool(progress_bar)


class StageBar(TQDMProgressBar):
    """Lightning's bar with the stage's name as description and its loss after the step count."""

    def __init__(self, stage: str) -> None:
        super().__init__()
        self.stage = stage

    @property
    def train_description(self) -> str:
        return self.stage

    def init_train_tqdm(self):
        bar = super().init_train_tqdm()
        bar.dynamic_ncols = False
        bar.ncols, bar.nrows = shutil.get_terminal_size()  # tqdm draws nothing on a terminal of 0 rows
        return bar

    def on_train_epoch_start(self, trainer, *args) -> None:
        super().on_train_epoch_start(trainer, *args)
        self.train_progress_bar.set_description(self.stage)

    def get_metrics(self, trainer, pl_module) -> dict[str, str]:
        loss = trainer.callback_metrics.get("train/loss")
        return {} if loss is None else {"loss": f"{float(loss):.4g}"}


class StageLog(Callback):
    """Without a bar: a log line every ``every_s`` seconds of wall time (0: none) while the stage
    fits, with its step, loss, seconds so far and an ETA from the mean pace; none at the last step,
    which `log_stage` reports. ``clock``: seconds (None: time.monotonic)."""

    def __init__(self, stage: str, every_s: float, clock: Callable[[], float] | None = None) -> None:
        self.stage, self.every_s, self.clock = stage, every_s, clock or time.monotonic
        self.start = self.last = 0.0

    def on_train_start(self, trainer, pl_module) -> None:
        self.start = self.last = self.clock()

    def on_train_batch_end(self, trainer, pl_module, outputs, batch, batch_idx) -> None:
        now = self.clock()
        step, total, elapsed = trainer.global_step, trainer.max_steps, now - self.start
        if self.every_s <= 0 or now - self.last < self.every_s or step >= total:
            return
        self.last = now
        loss = float(outputs["loss"] if isinstance(outputs, dict) else outputs)  # waits for the device: rarely
        log.info("stage %s: step %d/%d, loss %.4g, %.0f s, ETA %.0f s", self.stage, step, total, loss, elapsed,
                 elapsed / max(step, 1) * (total - step))


def log_stage(stage: str, result: dict) -> None:
    """One line for a finished stage: its name, steps, final loss and seconds."""
    loss = result["losses"].get("loss", float("nan"))
    log.info("stage %s: %d steps, loss %.4g, %.1f s", stage, result["steps"], loss, result["wall_time_s"])
