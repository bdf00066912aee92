"""The ``nct`` command in-process: configuration errors are one line with exit code 2, a missing
GPU or optional extra names its fix, and ``--help`` lists only the groups users pick."""

from __future__ import annotations

import importlib.util

import numpy as np
import pytest
import torch

from nct.cli import main as cli
from nct.errors import InputError
from nct.fit.trainer import check_accelerator
from nct.run.phases import Instant

QUICK = ["debug=tiny", "logger=none", "method=fbp"]


@pytest.mark.parametrize("args, message", [
    (["+phantom.displacment_deg=50"], "unknown key phantom.displacment_deg: not a setting of phantom (CircleConf); "
                                      "did you mean phantom.displacement_deg?"),
    (["phantom.displacment_deg=50"], "unknown key phantom.displacment_deg: not a setting of phantom (CircleConf); "
                                     "did you mean phantom.displacement_deg?"),
    (["+export.gifs=false"], "unknown key export.gifs: not a setting of export (ExportConf); did you mean export.gif?"),
    (["+optim.learning_rate=1"], "unknown key optim.learning_rate: not a setting of optim (OptimConf); its keys: "
                                 "init_steps, fit_steps, refine, refine_init_steps, refine_fit_steps, refine_lr, lr, "
                                 "warmup_steps, lr_decay, lr_decay_every, batch_views, min_loss, fit_intensities, "
                                 "intensity_lr, background_lr, divergence_factor, coarse_size, fit_size"),
    # a config group is the nearer name (not the key export); a key of another option of its group names that option
    (["expriment=heart_cine"], "unknown key expriment: not a setting of the config; did you mean the config group "
                               "experiment (experiment=<option>: bar, circle, heart, heart_cine, letters, nodule, "
                               "static, thorax)?"),
    (["data.path=x.npz"], "unknown key data.path: not a setting of data (SimulateConf); it is a setting of "
                          "data=file: did you mean data=file?"),
    (["+scanner.source_distance=3"], "unknown key scanner.source_distance: not a setting of scanner (ScannerConf); "
                                     "it is a setting of scanner=fan: did you mean scanner=fan?"),
    (["optm=fast"], "unknown key optm: not a setting of the config; did you mean optim?"),
    # a key of another group names that group (the callbacks' settings are not Trainer arguments)
    (["trainer.snapshot_every_n_steps=25"], "unknown key trainer.snapshot_every_n_steps: not a setting of trainer "
                                            "(TrainerArgs); it is a setting of the config group callbacks: did you "
                                            "mean callbacks.snapshot_every_n_steps?"),
    (["phantom.displacement_deg=abc"], "Error merging override phantom.displacement_deg=abc: Value 'abc' of type "
                                       "'str' could not be converted to Float (key: phantom.displacement_deg)"),
    (["phantom=unknown"], "In 'config': Could not find 'phantom/unknown'; Available options in 'phantom': circle, "
                          "composed, heart, letters, static"),
    (["optim.lr=0"], "optim.lr must be > 0, got 0.0"),
    (["scanner=fan", "scanner.detector_distance=-1"], "scanner.detector_distance must be > 0, got -1.0"),
    (["scanner=fan", "scanner.detector_shape=round"], "scanner.detector_shape must be 'flat' or 'curved', got 'round'"),
])
def test_config_errors_are_one_line_with_exit_code_2(nct, args, message):
    code, _, err = nct(*QUICK, *args)
    assert (code, err) == (2, f"nct: error: {message}\n")


def test_a_refused_input_leaves_no_run_folder(nct, tmp_path):
    """A bad setting or a file refused by its checks: one line, and no run folder left behind."""
    np.savez(tmp_path / "bad.npz", sinogram=np.ones((4, 4), np.float32), angles=np.zeros(4), times=np.zeros(4))
    for args, says in ((["phantom.displacement_deg=500"], "phantom.displacement_deg"),
                       (["data=file", "data.path=bad.npz", "method=fbp"], "'bin_spacing'")):  # the file's, once running
        code, _, err = nct("debug=tiny", "logger=none", *args)
        assert code == 2 and err.startswith("nct: error: ") and says in err
    assert not (tmp_path / "outputs").exists() or not any((tmp_path / "outputs" / "runs").iterdir())


def test_missing_optuna_extra_names_the_install_command(nct):
    if importlib.util.find_spec("hydra_plugins.hydra_optuna_sweeper"):
        pytest.skip("the optuna extra is installed here")
    code, _, err = nct("hparams_search=tv_fmax")
    assert code == 2 and err.count("\n") == 1
    assert err.startswith("nct: error: Hydra's optuna sweeper plugin is not installed: pip install '.[optuna]'")


def test_gpu_without_cuda_names_the_fix(nct, monkeypatch):
    monkeypatch.setattr(torch.cuda, "is_available", lambda: False)
    monkeypatch.setattr(torch.backends.mps, "is_available", lambda: False)
    with pytest.raises(InputError, match="install a CUDA build of torch .*, or use trainer=cpu$"):
        check_accelerator("gpu")
    check_accelerator("cpu")
    code, _, err = nct("debug=tiny", "logger=none", "trainer=gpu")
    assert code == 2 and err.count("\n") == 1 and err.startswith("nct: error: trainer.accelerator=gpu: torch ")


def test_help_lists_only_the_groups_users_pick(nct):
    code, out, _ = nct("--help")
    groups = out.split("== Configuration groups ==")[1].split("== Config ==")[0]
    names = {line.split(":")[0] for line in groups.splitlines()[2:] if ":" in line}
    assert code == 0 and names == {"background", "callbacks", "data", "debug", "experiment", "fbp", "heldout",
                                   "hparams_search", "image", "init", "logger", "loss", "model", "motion", "optim",
                                   "phantom", "render", "scanner", "suspect", "sweep", "trainer"}
    assert "sweep: displacement, displacement_quick, fmax, fmax_quick, lambda_grid, lambda_grid_quick" in groups
    assert "trainer: cpu, gpu" in groups and "callbacks: default" in groups


def test_a_single_run_is_timed_from_the_process_start(monkeypatch):
    monkeypatch.setattr(cli, "_PROCESS_START", [(1.0, 0.5)])
    assert cli.job_start(single=True) == Instant(1.0, 0.5)  # wall clock and CPU seconds alike
    assert cli.job_start(single=True).wall > 1.0  # claimed: a later run in the same process starts its own clock
    monkeypatch.setattr(cli, "_PROCESS_START", [(1.0, 0.5)])
    assert cli.job_start(single=False).wall > 1.0  # a sweep's job: from its own start
