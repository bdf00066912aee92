"""JSON records written whole or not at all: a run killed while writing one (status, metrics, a stage's
record, a benchmark job's) leaves the record before it, never a truncated file that a resume then reads."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any


def write_json(path: Path, payload: Any, indent: int | None = None) -> None:
    """``payload`` as JSON at ``path``, through a temporary file beside it renamed over ``path`` (atomic)."""
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(json.dumps(payload, indent=indent))
    tmp.replace(path)
