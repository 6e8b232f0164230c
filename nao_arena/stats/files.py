"""File output of the statistics: CSV text of summary rows, written atomically (the JSON
form is :meth:`nao_arena.stats.EpisodeSummary.to_json`)."""

from __future__ import annotations

import csv
import io
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from nao_arena.atomic import atomic_write_text

__all__ = ["csv_text", "write_csv"]


def csv_text(rows: Sequence[dict[str, Any]], columns: Sequence[str]) -> str:
    """rows as CSV text with a header of columns (None as an empty field, "\\n" line ends)."""
    buf = io.StringIO()
    writer = csv.DictWriter(buf, fieldnames=list(columns), lineterminator="\n")
    writer.writeheader()
    for row in rows:
        writer.writerow({k: ("" if row[k] is None else row[k]) for k in columns})
    return buf.getvalue()


def write_csv(path: str | Path, rows: Sequence[dict[str, Any]], columns: Sequence[str]) -> None:
    """Write rows as CSV (see :func:`csv_text`) to path, atomically."""
    atomic_write_text(path, csv_text(rows, columns))
