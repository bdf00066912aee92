"""A stage's callbacks: the divergence check reads the loss on the Trainer's logging steps and the last."""

from __future__ import annotations

from types import SimpleNamespace

import pytest
import torch

from nct.errors import DivergenceError
from nct.fit.callbacks import DivergenceCheck


def test_divergence_check_catches_nan():
    check = DivergenceCheck("fit", 10.0)
    trainer = SimpleNamespace(global_step=3, optimizers=[SimpleNamespace(param_groups=[{"lr": 1e-3}])],
                              log_every_n_steps=1, max_steps=10)
    for step, loss in enumerate([0.5, 0.2, 4.9, 0.01]):  # limit: 10 x the first loss
        check.on_train_batch_end(trainer, None, {"loss": torch.tensor(loss)}, None, step)
    with pytest.raises(DivergenceError, match="loss nan"):
        check.on_train_batch_end(trainer, None, {"loss": torch.tensor(float("nan"))}, None, 4)
    with pytest.raises(DivergenceError, match="first step 0.5, limit 10x"):
        check.on_train_batch_end(trainer, None, {"loss": torch.tensor(5.1)}, None, 5)


def test_divergence_is_checked_on_logging_steps_and_the_last():
    check = DivergenceCheck("fit", 10.0)
    trainer = SimpleNamespace(global_step=0, optimizers=[SimpleNamespace(param_groups=[{"lr": 1e-3}])],
                              log_every_n_steps=5, max_steps=12)
    check.on_train_batch_end(trainer, None, {"loss": torch.tensor(1.0)}, None, 0)
    check.on_train_batch_end(trainer, None, {"loss": torch.tensor(float("nan"))}, None, 2)  # not read
    with pytest.raises(DivergenceError, match="loss nan"):
        check.on_train_batch_end(trainer, None, {"loss": torch.tensor(float("nan"))}, None, 4)  # step 5
    with pytest.raises(DivergenceError, match="loss 20"):
        check.on_train_batch_end(trainer, None, {"loss": torch.tensor(20.0)}, None, 11)  # the last step
