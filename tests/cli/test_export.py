"""nct-export: a finished run's field re-rendered from its checkpoint, against the run's own frames."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest
import torch
from omegaconf import OmegaConf

from nct.cli.export import main
from nct.method.reload import load_run
from nct.run.job import run_job
from tests.conftest import TINY, compose_config

QUIET = ["logger=csv", "threads=1", "export.gif=false", "export.png=false", "export.tiff=false"]
VARIANTS = {  # each in units of its own (fit/units.py): the export maps back like the run
    "refine": ["optim.refine=true", "optim.refine_init_steps=3", "optim.refine_fit_steps=3", "image.extent=1.5"],
    # a still object: the static rung wins though fitted first (the free rung fitted too: still_ratio 0)
    "auto": ["motion.rungs=[static,free]", "motion.still_ratio=0", "phantom.displacement_deg=0",
             "phantom.intensity=3.0"],
    # two rotations (of half the time: the same 0.25 s)
    "rotations": ["scanner.rotations=2", "scanner.rotation_time=0.125", "image.extent=1.5"],
    # a static background image under the object, rendered beside it at any size
    "background": ["background=image", "image.extent=1.5"],
}


def make_run(folder: Path, overrides: list[str]) -> Path:
    """One tiny run through the pipeline, with its config in .hydra/ (run_job writes it)."""
    run_job(compose_config(TINY + QUIET + overrides), folder)
    return folder


@pytest.fixture(scope="module", params=list(VARIANTS))
def run(request, tmp_path_factory) -> Path:
    return make_run(tmp_path_factory.mktemp(request.param) / "run", VARIANTS[request.param])


@pytest.fixture(scope="module")
def fbp_run(tmp_path_factory) -> Path:
    return make_run(tmp_path_factory.mktemp("fbp") / "run", ["method=fbp"])


def export(*argv) -> dict[str, np.ndarray]:
    """Run nct-export in-process; the arrays of the .npz it wrote."""
    main([str(a) for a in argv])
    out = Path(argv[argv.index("--out") + 1])
    with np.load(out) as npz:
        return dict(npz)


def refused(capsys, *argv) -> str:
    """The one line nct-export ends with (exit code 2)."""
    with pytest.raises(SystemExit) as stop:
        main([str(a) for a in argv])
    assert stop.value.code == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("nct-export: error: "), err
    return err


def test_own_times_and_grid_give_the_runs_frames(run, tmp_path):
    units = json.loads((run / "metrics.json").read_text())["init"]
    assert units["length_unit"] == 1.5 or units["intensity_unit"] > 2  # not the method's own units
    rec = np.load(run / "reconstruction.npz")
    size = rec["nct"].shape[-1]
    out = export(run, "--times", *rec["times"], "--size", size, "--out", tmp_path / "own.npz")
    np.testing.assert_array_equal(out["times"], rec["times"])
    np.testing.assert_allclose(out["frames"], rec["nct"], rtol=0, atol=1e-6 * float(rec["nct"].max()))
    assert out["sdf"].shape == (len(rec["times"]), 1, size, size)


def test_even_frames_are_the_runs_frame_times(run, tmp_path):
    """A simulated run's frames sit centred in equal slots of the acquisition; so do --frames N's."""
    rec = np.load(run / "reconstruction.npz")
    out = export(run, "--frames", len(rec["times"]), "--out", tmp_path / "even.npz")
    np.testing.assert_allclose(out["times"], rec["times"], rtol=0, atol=1e-12)
    np.testing.assert_allclose(out["frames"], rec["nct"], rtol=0, atol=1e-6 * float(rec["nct"].max()))


def test_any_size_samples_the_same_image(run, tmp_path):
    """At 3x the run's size every third pixel centre is one of the run's: the same SDF and, the
    occupancy ramp keeping its physical width, the same intensity there."""
    rec = np.load(run / "reconstruction.npz")
    size = rec["nct"].shape[-1]
    fine = export(run, "--frames", 4, "--size", 3 * size, "--out", tmp_path / "fine.npz")
    own = export(run, "--frames", 4, "--out", tmp_path / "own.npz")
    np.testing.assert_allclose(fine["sdf"][..., 1::3, 1::3], own["sdf"], rtol=0, atol=1e-5)
    np.testing.assert_allclose(fine["frames"][:, 1::3, 1::3], own["frames"], rtol=0, atol=1e-5)


def test_shapes_files_and_sdf_agree_with_frames(run, capsys):
    main([str(run), "--frames", "48", "--size", "256", "--gif", "--tiff"])
    out = run / "export_48x256.npz"
    assert capsys.readouterr().out.split() == [str(out), str(out.with_suffix(".gif")), str(out.with_suffix(".tiff"))]
    with np.load(out) as npz:
        frames, sdf, times = npz["frames"], npz["sdf"], npz["times"]
    assert frames.shape == (48, 256, 256) and frames.dtype == np.float32
    assert sdf.shape == (48, 1, 256, 256) and sdf.dtype == np.float32 and times.shape == (48,)
    a = json.loads((run / "metrics.json").read_text())["intensities"][0]
    fitted = load_run(run).fitted
    if fitted.field.background is not None:  # the static background under the object, at the export's size
        b = torch.nn.functional.interpolate(fitted.field.background.detach()[None, None], size=(256, 256),
                                            mode="bilinear", align_corners=False)[0, 0]
        frames = frames - b.numpy() * fitted.units.intensity
    clear = np.abs(sdf[:, 0]) > 1e-4  # occupancy is 1/2 on the zero level set: inside iff above a/2
    np.testing.assert_array_equal((frames > a / 2)[clear], (sdf[:, 0] > 0)[clear])
    assert 0 < (sdf > 0).mean() < 0.5


def test_never_overwrites(run, capsys):
    before = (run / "reconstruction.npz").read_bytes()
    err = refused(capsys, run, "--frames", 2, "--out", run / "reconstruction.npz")
    assert "never overwritten" in err and (run / "reconstruction.npz").read_bytes() == before


def test_the_field_file_holds_the_winners_last_stage(run):
    """The field file restores every tensor of the last stage fitted to the winner (its Lightning checkpoint,
    the field the run's frames came from), the frequencies ``omega`` included."""
    fitted = load_run(run).fitted
    cfg = OmegaConf.load(run / ".hydra" / "config.yaml")
    winner = json.loads((run / "metrics.json").read_text())["selection"]["winner"]
    stage = "refine_fit" if cfg.optim.refine else f"{winner}_fit"
    saved = torch.load(run / "checkpoints" / stage / "last.ckpt", weights_only=True)["state_dict"]
    for key, value in fitted.field.state_dict().items():
        torch.testing.assert_close(value, saved["field." + key], rtol=0, atol=0)
    if cfg.motion.still_ratio == 0:  # the "auto" variant: both rungs fitted
        assert winner == "static" and fitted.field.n_terms == 0 and (run / "checkpoints" / "free_fit").is_dir()


def test_fbp_only_run_is_refused(fbp_run, capsys):
    assert "FBP-only" in refused(capsys, fbp_run, "--frames", 4)


@pytest.mark.parametrize("argv, says", [
    (["--times", "0.1", "9"], "outside the acquisition, 0 s to 0.25 s"),
    (["--frames", "0"], "--frames must be >= 1"),
    (["--frames", "4", "--size", "1"], "--size must be >= 2"),
    (["--frames", "4", "--times", "0.1"], "not allowed with"),
    (["--frames", "4", "--out", "x.png"], "must name an .npz"),
])
def test_bad_arguments_are_refused(run, capsys, argv, says):
    assert says in refused(capsys, run, *argv)


def test_run_without_checkpoints_is_refused(run, tmp_path, capsys):
    copy = shutil.copytree(run, tmp_path / "run", ignore=shutil.ignore_patterns("checkpoints"))
    assert "no checkpoint" in refused(capsys, copy, "--frames", 4)


def test_a_checkpoint_of_an_older_nct_is_refused(run, tmp_path, capsys):
    copy = shutil.copytree(run, tmp_path / "run")
    path = copy / "checkpoints" / "field.pt"
    saved = torch.load(path, weights_only=True)
    saved["state_dict"] = {k: v for k, v in saved["state_dict"].items() if k != "omega"}
    torch.save(saved, path)
    assert "written by an older nct (its checkpoint has no omega)" in refused(capsys, copy, "--frames", 4)


def test_unfinished_and_non_run_folders_are_refused(run, tmp_path, capsys):
    assert "not a run folder" in refused(capsys, tmp_path, "--frames", 4)
    (tmp_path / ".hydra").mkdir()
    (tmp_path / ".hydra" / "config.yaml").write_text((run / ".hydra" / "config.yaml").read_text())
    (tmp_path / "status.json").write_text(json.dumps({"status": "running"}))
    assert "did not finish (status.json: running)" in refused(capsys, tmp_path, "--frames", 4)


def test_a_run_without_a_logger_keeps_its_checkpoints(tmp_path):
    """logger=none turns off TensorBoard, not the checkpoints nct-export and resume read."""
    from nct.run.job import run_job
    from tests.conftest import TINY, compose_config

    run_job(compose_config(TINY + ["logger=none", "export.gif=false", "export.png=false", "export.tiff=false"]),
            tmp_path / "run")
    assert sorted(p.parent.name for p in (tmp_path / "run" / "checkpoints").glob("*/last.ckpt")) == ["free_fit", "free_init"]
    assert not (tmp_path / "run" / "tb").exists()
