"""Tables for people and spreadsheets: one CSV writer and one markdown-table format.

Shared by `nct.analysis.report` (sweep reports) and `nct.analysis.benchmarking` (benchmark notes), so that every
table nct writes formats numbers and missing values alike.
"""

from __future__ import annotations

import csv
import math
import numbers
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path

#: What a cell shows for a value that is not there (None, NaN).
MISSING = "–"


def write_csv(rows: Sequence[Mapping[str, object]], path: Path, columns: Sequence[str] | None = None) -> Path:
    """``rows`` as CSV at ``path`` (its folder made if needed); returns ``path``.

    columns: their order; default every key of ``rows`` in first-seen order. A cell a row lacks, or
    holds None, is empty; numbers are written in full (``repr``), NaN as ``nan``.
    """
    columns = list(columns) if columns is not None else list(dict.fromkeys(k for row in rows for k in row))
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "w", newline="") as fh:
        writer = csv.DictWriter(fh, columns, restval="")
        writer.writeheader()
        writer.writerows(rows)
    return path


def fmt(value: object, digits: int = 3) -> str:
    """A cell: a real number to ``digits`` significant digits, whole from ``10**digits`` on (12346, not
    1.23e+04); None and NaN as `MISSING`; anything else (integers, text) as ``str``."""
    if value is None:
        return MISSING
    if isinstance(value, numbers.Real) and not isinstance(value, numbers.Integral):
        value = float(value)
        if math.isnan(value):
            return MISSING
        return f"{value:.0f}" if abs(value) >= 10**digits else f"{value:.{digits}g}"
    return str(value)


def markdown_table(header: Sequence[str], rows: Sequence[Sequence[object]]) -> str:
    """A GitHub markdown table of `fmt` cells (a ``|`` inside a cell escaped), one line per row."""
    lines = [_md_row(header), "|" + "---|" * len(header)]
    return "\n".join(lines + [_md_row(fmt(cell) for cell in row) for row in rows])


def _md_row(cells: Iterable[object]) -> str:
    return "| " + " | ".join(str(c).replace("|", "\\|") for c in cells) + " |"
