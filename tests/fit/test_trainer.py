"""Running a stage: Lightning's advice to the user stays out of the run's output."""

from __future__ import annotations

import warnings

import lightning as L
from lightning.pytorch.accelerators import CUDAAccelerator

from nct.fit.trainer import quiet_lightning


def test_a_cpu_run_on_a_machine_with_a_gpu_prints_no_lightning_advice(monkeypatch):
    """On a GPU machine Lightning warns "GPU available but not used" to stderr on every stage of a
    ``trainer=cpu`` run, breaking the one-line error contract (seen on an H200 host)."""
    monkeypatch.setattr(CUDAAccelerator, "is_available", staticmethod(lambda: True))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        L.Trainer(accelerator="cpu", logger=False, enable_progress_bar=False, enable_model_summary=False)
        assert any("GPU available but not used" in str(w.message) for w in caught)  # what the filter is for
        caught.clear()
        with quiet_lightning():
            L.Trainer(accelerator="cpu", logger=False, enable_progress_bar=False, enable_model_summary=False)
    assert not caught, [str(w.message) for w in caught]
