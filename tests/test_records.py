"""JSON records are written whole or not at all."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from nct.records import write_json


def test_a_record_is_replaced_whole_or_left_as_it_was(tmp_path, monkeypatch):
    path = tmp_path / "stage.json"
    write_json(path, {"steps": 1}, indent=2)
    assert json.loads(path.read_text()) == {"steps": 1} and path.read_text().startswith("{\n  ")
    write = Path.write_text

    def cut_short(self, text, *args, **kwargs):  # a run killed (or a disk full) halfway through the write
        write(self, text[: len(text) // 2], *args, **kwargs)
        raise OSError("no space left on device")

    monkeypatch.setattr(Path, "write_text", cut_short)
    with pytest.raises(OSError):
        write_json(path, {"steps": 2, "losses": [0.5] * 10})
    monkeypatch.undo()
    assert json.loads(path.read_text()) == {"steps": 1}  # the record before, whole
    write_json(path, {"steps": 3})
    assert json.loads(path.read_text()) == {"steps": 3}
