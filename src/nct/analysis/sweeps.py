"""The Optuna search starts from the default configuration: its storage holds the study with the
defaults enqueued as the first trial, so that the best trial can never score below the defaults.

Hydra's Optuna sweeper has no hook that runs before its first trial, but it passes its ``storage``
to ``optuna.create_study(..., load_if_exists=True)``: `study_storage` is that storage, instantiated
by Hydra from ``hydra.sweeper.storage`` (see conf/hparams_search/tv_fmax.yaml). Needs the optuna extra.
"""

from __future__ import annotations

import logging
import sys
import warnings
from collections.abc import Mapping
from typing import Any

import optuna
from optuna.storages import BaseStorage

from nct.errors import InputError


def study_storage(url: str | None, study_name: str | None, direction: str, first: Mapping[str, Any]) -> BaseStorage:
    """The storage at ``url`` (None: in memory) holding study ``study_name`` optimised in ``direction``,
    with ``first`` (each searched key: its value in the composed config) enqueued unless the study
    already has trials (a database resumed)."""
    if study_name is None:
        raise InputError("hydra.sweeper.study_name must be set: the sweeper finds the study holding the "
                         "enqueued defaults by its name")
    quiet_optuna()
    storage = optuna.storages.get_storage(url)
    study = optuna.create_study(storage=storage, study_name=study_name, direction=direction, load_if_exists=True)
    if not study.trials:
        with warnings.catch_warnings():  # "enqueue_trial is experimental" in optuna 2; stable since 3
            warnings.simplefilter("ignore", optuna.exceptions.ExperimentalWarning)
            study.enqueue_trial(dict(first))
    return storage


def quiet_optuna() -> None:
    """Optuna's log at warnings only, coloured only on a terminal. Its import sets its logger to INFO
    with its own colour handler, after Hydra's logging config: so here, not in hydra_logging."""
    optuna.logging.set_verbosity(logging.WARNING)
    if not sys.stderr.isatty():
        optuna.logging.disable_default_handler()  # its records go through Hydra's plain handlers instead
        optuna.logging.enable_propagation()
