"""How a run ended, read from its folder: every missing or broken file is an outcome with a reason."""

import json
from pathlib import Path

import pytest

from nct.run.outcome import FINISHED, UNFINISHED, Outcome, read_outcome


def run_folder(root: Path, status: object = None, metrics: object = None) -> Path:
    root.mkdir()
    for name, content in (("status.json", status), ("metrics.json", metrics)):
        if content is not None:
            (root / name).write_text(content if isinstance(content, str) else json.dumps(content))
    return root


@pytest.mark.parametrize(("status", "metrics", "expected"), [
    (None, None, Outcome(UNFINISHED, "no status.json: never started, or killed before it began")),
    ([1, 2], None, Outcome(UNFINISHED, "unreadable status.json: not a JSON object")),
    ({"status": "running", "error": None, "wall_time_s": 2}, None,
     Outcome("running", "status running: still running, or interrupted", 2.0)),
    ({"status": "diverged", "error": "DivergenceError: loss is nan", "wall_time_s": 1.5}, {"nct": {}},
     Outcome("diverged", "DivergenceError: loss is nan", 1.5)),
    ({"status": "ok", "error": None, "wall_time_s": True}, None,
     Outcome(FINISHED, "metrics.json missing or unreadable")),
    ({"status": "ok", "error": None, "wall_time_s": 4.0}, {"heldout_loss": 0.1},
     Outcome(FINISHED, None, 4.0, {"heldout_loss": 0.1})),
    ({"status": "ok", "error": None, "wall_time_s": 4.0, "warnings": ["suspect fit: a"]}, {"heldout_loss": 0.1},
     Outcome(FINISHED, None, 4.0, {"heldout_loss": 0.1}, ("suspect fit: a",))),
])
def test_read_outcome(tmp_path: Path, status, metrics, expected: Outcome):
    assert read_outcome(run_folder(tmp_path / "run", status, metrics)) == expected


def test_benchmark_scores_an_unreadable_metrics_file_invalid(tmp_path: Path):
    from nct.analysis.benchmarking import read_run

    run = run_folder(tmp_path / "run", {"status": "ok", "error": None, "wall_time_s": 1.0}, "{")
    fields = read_run(run, "nct")
    assert fields["status"] == "invalid" and fields["error"].startswith("metrics.json missing or unreadable: unreadable")


def test_unparsable_status_is_unfinished_with_the_parser_error(tmp_path: Path):
    outcome = read_outcome(run_folder(tmp_path / "run", "{not json"))
    assert outcome.status == UNFINISHED and outcome.error.startswith("unreadable status.json: Expecting")
