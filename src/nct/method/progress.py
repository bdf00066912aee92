"""What a run shows while it fits: a bar per stage in a terminal, one log line per stage otherwise.

Lightning's TQDM bar sizes itself to the terminal. A terminal that reports a size of 0 x 0 (a
pty whose size nobody set: some IDE consoles and container shells, ``script``) left tqdm no row to
draw on, so only the newline at the bar's end appeared: blank lines. The bar here takes the size
``shutil.get_terminal_size`` gives, which falls back to $COLUMNS/$LINES or 80 x 24.
"""

from __future__ import annotations

import logging
import shutil
import sys

from lightning.pytorch.callbacks import TQDMProgressBar

log = logging.getLogger(__name__)


def show_bar(progress_bar: bool | None) -> bool:
    """The ``trainer.progress_bar`` setting: on when asked, or (None) when stdout is a terminal."""
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


def log_stage(stage: str, result: dict) -> None:
    """One line for a finished stage: its name, steps, final loss and seconds."""
    loss = result["losses"].get("loss", float("nan"))
    log.info("stage %s: %d steps, loss %.4g, %.1f s", stage, result["steps"], loss, result["wall_time_s"])
