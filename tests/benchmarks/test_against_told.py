"""benchmarks/diagnostics/against_told.py: a call with nothing passed against one told each scene's model."""

import pytest

from tests.conftest import load_benchmark, write_table

A = load_benchmark("diagnostics/against_told")
P = load_benchmark("diagnostics/patched_table")  # the tables' reader
TOLD = ("scene", "motions", "winner", "nct_status", "nct_dice", "nct_mse", "fbp_dice", "fbp_mse")
CHOSEN = (*TOLD, "chosen_k", "chosen_background", "model_right", "model_equivalent", "below_fbp")


def test_the_shared_scenes_are_summarised_and_each_other_model_costed(tmp_path):
    told = write_table(tmp_path / "told.csv", TOLD,
                       [("s0", "beat static", "free", "ok", 0.990, 1e-4, 0.98, 1e-3),
                        ("s1", "rotation", "free", "ok", 0.999, 1e-5, 0.99, 1e-3),
                        ("s2", "static static", "free", "ok", 0.995, 2e-5, 0.99, 1e-3),
                        ("s9", "orbit", "free", "ok", 0.9, 1e-3, 0.8, 1e-2),
                        ("s3", "static", "free", "diverged", "nan", "nan", 0.99, 1e-3)])
    rows = [("s0", "beat static", "k1_image_free", "ok", 0.997, 3e-5, 0.98, 1e-3, 1, "image", False, True, False),
            ("s1", "rotation", "free", "ok", 0.999, 1e-5, 0.99, 1e-3, 1, "none", True, True, False),
            ("s2", "static static", "k1_none_static", "ok", 0.970, 9e-4, 0.99, 1e-3, 1, "none", False, False, True),
            ("s3", "static", "static", "ok", 0.995, 1e-5, 0.99, 1e-3, 1, "none", True, True, False)]
    chosen = write_table(tmp_path / "chosen.csv", CHOSEN, rows)
    assert A.main([str(told), str(chosen), "--out", str(tmp_path / "note.md")]) == 0
    summary = dict(A.summary(P.read(told), P.read(chosen)))
    assert summary["scenes"] == 4 and summary["median Dice, nothing passed / told"] == "0.9960 / 0.9925"
    assert summary["losses / gains over 0.005"] == "1 / 2" and summary["below FBP - 0.01, nothing passed"] == "s2"
    assert summary["the truth's model (K ellipses, no background)"] == 2
    assert summary["its moving ellipses over an image holding the still ones"] == 1
    note = (tmp_path / "note.md").read_text()
    assert "The 2 shared scenes whose run chose a model other than the truth's" in note
    assert "| s2 | static static | k1_none_static | 1 | none | -0.0250 |" in note and "| s1 |" not in note


def test_a_told_table_as_the_second_or_a_missing_table_is_a_one_line_error(tmp_path, capsys):
    told = write_table(tmp_path / "told.csv", TOLD, [("s0", "orbit", "free", "ok", 0.99, 1e-5, 0.9, 1e-3)])
    for args, says in (([told, told], "no model_right column"), ([told, tmp_path / "no.csv"], "no table")):
        with pytest.raises(SystemExit):
            A.main([*map(str, args), "--out", str(tmp_path / "note.md")])
        assert says in capsys.readouterr().err
    assert not (tmp_path / "note.md").exists()
