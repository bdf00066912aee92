"""The one CSV writer and markdown-table format that the sweep report and the benchmarks share."""

import csv
import math
from pathlib import Path

import numpy as np

from nct.run.tables import MISSING, fmt, markdown_table, write_csv


def test_markdown_table_formats_numbers():
    assert markdown_table(["a", "b"], [["x", 0.123456], ["y", math.nan], ["z", 12345.6]]).splitlines() == [
        "| a | b |", "|---|---|", "| x | 0.123 |", "| y | – |", "| z | 12346 |"]


def test_markdown_table_escapes_pipes_and_keeps_text_and_integers():
    assert markdown_table(["what", "n"], [["RuntimeError: a|b", 3], ["", None]]).splitlines()[2:] == [
        "| RuntimeError: a\\|b | 3 |", "|  | – |"]


def test_fmt_digits_missing_and_numpy():
    assert fmt(0.000123456, 4) == "0.0001235" and fmt(1234.5, 4) == "1234" and fmt(12345.6, 4) == "12346"
    assert fmt(0.0123, 2) == "0.012" and fmt(150.0, 2) == "150"  # whole from 10**digits on, never 1.5e+02
    assert fmt(None) == fmt(math.nan) == fmt(np.float32("nan")) == MISSING
    assert fmt(np.float32(0.5)) == "0.5" and fmt(np.int64(7)) == "7" and fmt(True) == "True" and fmt("x") == "x"
    assert fmt(math.inf) == "inf"


def test_write_csv_columns_first_seen_or_given_and_empty_cells(tmp_path: Path):
    rows = [{"a": 1, "b": 0.5}, {"c": "x", "a": 2, "b": None}]
    path = write_csv(rows, tmp_path / "sub" / "t.csv")
    assert path.read_text().splitlines() == ["a,b,c", "1,0.5,", "2,,x"]
    with open(write_csv(rows, tmp_path / "u.csv", ["c", "a", "b"]), newline="") as fh:
        assert list(csv.reader(fh)) == [["c", "a", "b"], ["", "1", "0.5"], ["x", "2", ""]]
