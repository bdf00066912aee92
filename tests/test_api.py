"""nct from Python (nct/api.py): the command line's frames bit for bit, settings validated as the command's,
a light ``import nct``, and the documented example run as it is."""

from __future__ import annotations

import csv
import json
import runpy
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

import nct
from nct.acquisition.io import save_sinogram
from nct.api import configure
from nct.errors import InputError
from tests.conftest import moving_disc

EXAMPLE = Path(__file__).resolve().parents[1] / "docs" / "examples" / "reconstruct.py"
SHORT = {"init_steps": 5, "fit_steps": 5, "refine": False}  # TINY's fits (tests/conftest.py)
SHORT_CLI = [f"optim.{key}={str(value).lower()}" for key, value in SHORT.items()]
NO_PICTURES = ["logger=none", "export.gif=false", "export.png=false", "export.tiff=false"]  # arrays are compared


@pytest.fixture(scope="module")
def scan_file(tmp_path_factory) -> Path:
    """The moving disc of tests/conftest.py as a sinogram file, with its truth frames."""
    path = tmp_path_factory.mktemp("data") / "scan.npz"
    save_sinogram(path, moving_disc()[0])
    return path


@pytest.mark.parametrize("with_truth", [True, False])
def test_python_gives_the_command_lines_frames_bit_for_bit(request, scan_file, tmp_path, with_truth):
    """Issue 49's first test: the same file and settings give the same arrays, selection and warnings;
    without a truth the frames' size and rate are the scan's (image.size, image.frames_per_rotation)."""
    cli = request.getfixturevalue("nct")  # the command in-process (tests/conftest.py), beside the package
    data = scan_file if with_truth else tmp_path / "bare.npz"
    grid = {} if with_truth else {"size": 24, "frames_per_rotation": 4}
    if not with_truth:
        save_sinogram(data, replace(moving_disc()[0], truth=None))
    cli_grid = [f"image.{key}={value}" for key, value in grid.items()]
    code, _, err = cli("data=file", f"data.path={data}", "data.n_objects=1", "seed=0", "threads=1", *SHORT_CLI,
                       *cli_grid, *NO_PICTURES, f"hydra.run.dir={tmp_path / 'run'}")
    assert code == 0, err
    rec = nct.reconstruct(nct.Scan.from_file(data, **grid), n_objects=1, seed=0, threads=1, optim=SHORT)
    with np.load(tmp_path / "run" / "reconstruction.npz") as written:
        for ours, theirs in (("frames", "nct"), ("fbp", "fbp"), ("masks", "nct_masks"), ("times", "times")):
            np.testing.assert_array_equal(getattr(rec, ours), written[theirs], err_msg=ours)
    with open(tmp_path / "run" / "selection.csv") as table:
        assert [row["candidate"] for row in csv.DictReader(table)] == [row.candidate for row in rec.selection]
    assert rec.warnings == json.loads((tmp_path / "run" / "status.json").read_text())["warnings"]
    loaded = nct.load(tmp_path / "run")  # a run folder reads back as a saved reconstruction
    np.testing.assert_array_equal(loaded.frames, rec.frames)
    np.testing.assert_array_equal(loaded.render(rec.times)[0], rec.render(rec.times)[0])


def test_settings_take_options_and_keys_as_the_command_line_does():
    conf = configure(None, {"optim": "fast", "motion": {"tolerance": 0.5, "rungs": ["static", "free"]},
                            "trainer": "gpu", "callbacks": {"snapshot_every_n_steps": 25}},
                     {"seed": 3, "data": {"n_objects": 2}})
    assert conf == nct.compose(["optim=fast", "motion.tolerance=0.5", "motion.rungs=[static,free]", "seed=3",
                                "data.n_objects=2", "trainer=gpu", "callbacks.snapshot_every_n_steps=25"])
    assert (conf.trainer.accelerator, conf.callbacks.snapshot_every_n_steps) == ("gpu", 25)


def test_a_config_is_the_start_and_arguments_left_none_keep_it():
    start = nct.compose(["optim.fit_steps=7", "seed=4", "data.n_objects=3"])
    conf = configure(start, {"motion": "auto"}, {"seed": None, "data": None})
    assert (conf.optim.fit_steps, conf.seed, conf.data.n_objects) == (7, 4, 3)
    assert conf.motion.rungs == ["static", "rigid", "affine", "free"]


@pytest.mark.parametrize("kwargs, says", [
    ({"optim": {"fitsteps": 5}},
     "unknown key optim.fitsteps: not a setting of optim (OptimConf); did you mean optim.fit_steps?"),
    ({"optim": {"fit_steps": "many"}}, "Value 'many' of type 'str' could not be converted to Integer"),
    ({"optim": {"fit_steps": -1}}, "optim.fit_steps"),
    ({"trainer": {"snapshot_every_n_steps": 25}}, "unknown key trainer.snapshot_every_n_steps: not a setting of "
     "trainer (TrainerArgs); it is a setting of the config group callbacks: did you mean "
     "callbacks.snapshot_every_n_steps?"),
    ({"motion": "bogus"}, "motion=bogus"),
    ({"optim": 5}, "optim: expected an option of the group (a str) or a dict of its keys, got int"),
    ({"image": {"size": 64}},
     "image: not a setting of nct.reconstruct: the output grid and frame times are the Scan's"),
    ({"optimm": {}}, "optimm: not a setting of nct.reconstruct; did you mean optim?"),
    ({"n_objects": 0}, "n_objects must be a whole number >= 1"),
    ({"config": {"seed": 1}}, "config: expected an NCTConf (nct.compose([...])), got dict"),
])
def test_bad_settings_are_one_line_naming_the_key(scan_file, kwargs, says):
    with pytest.raises(InputError) as err:
        nct.reconstruct(nct.Scan.from_file(scan_file), **kwargs)
    assert says in str(err.value) and "\n" not in str(err.value)


def test_import_nct_loads_no_torch_and_lists_the_api():
    code = "import sys, nct; print('torch' in sys.modules, sorted(set(nct.__all__) - set(dir(nct))))"
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert done.stdout.split() == ["False", "[]"]


def test_the_documented_example_runs(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    runpy.run_path(str(EXAMPLE), run_name="__main__")
    out = capsys.readouterr().out
    assert "median Dice" in out and "saved and loaded" in out
