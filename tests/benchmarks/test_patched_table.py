"""benchmarks/diagnostics/patched_table.py: a 100-scene table with the scenes a change touches replaced."""

import pytest

from tests.conftest import load_benchmark, write_table

P = load_benchmark("diagnostics/patched_table")
COLUMNS = ("scene", "n_objects", "winner", "chosen_k", "model_right", "nct_dice", "nct_mse", "fbp_dice", "fbp_mse",
           "wall_time_s")


def test_the_later_rows_replace_the_base_and_both_are_summarised(tmp_path):
    base = write_table(tmp_path / "base.csv", COLUMNS,
                       [("s0", 2, "k1_image_free", 1, False, 0.987, 2e-4, 0.998, 6e-4, 168),
                        ("s1", 1, "free", 1, True, 0.999, 1e-5, 0.99, 1e-3, 90),
                        ("s2", 3, "free", 2, False, 0.95, 2e-3, 0.9, 1e-3, 100)])
    after = write_table(tmp_path / "after.csv", COLUMNS,
                        [("s0", 2, "free_start1", 2, True, 0.999, 4e-5, 0.998, 6e-4, 366)])
    assert P.main([str(base), str(after), "--out", str(tmp_path / "out")]) == 0
    patched = P.read(tmp_path / "out" / "scenes.csv")
    assert list(patched) == ["s0", "s1", "s2"] and patched["s0"]["winner"] == "free_start1"
    assert P.summary(P.read(base)) == [3, "0.9870", 1, 1, "s0", "s2"]
    assert P.summary(patched) == [3, "0.9990", 2, 2, "none", "s2"]
    note = (tmp_path / "out" / "README.md").read_text()
    assert "| s0 | 2 | k1_image_free | 1 | 0.987 |" in note and "| free_start1 | 2 | 0.999 |" in note


def test_a_scene_the_base_lacks_or_a_missing_table_is_a_one_line_error(tmp_path, capsys):
    base = write_table(tmp_path / "base.csv", COLUMNS, [("s0", 1, "free", 1, True, 0.99, 1e-5, 0.99, 1e-3, 90)])
    after = write_table(tmp_path / "after.csv", COLUMNS, [("s9", 1, "free", 1, True, 0.99, 1e-5, 0.99, 1e-3, 90)])
    for args, says in (([base, after], "scenes not in the base table: s9"), ([base, tmp_path / "no.csv"], "no table")):
        with pytest.raises(SystemExit):
            P.main([*map(str, args), "--out", str(tmp_path / "out")])
        assert says in capsys.readouterr().err
    assert not (tmp_path / "out").exists()
