"""The CSV files of the validation studies: one row per record, floats to 6 digits."""

from __future__ import annotations

import csv
from collections.abc import Sequence
from dataclasses import asdict
from pathlib import Path


def write_csv(
    rows: Sequence,
    path: Path,
    columns: Sequence[str] | None = None,
    comment: str | None = None,
) -> None:
    """Write ``rows`` (dataclass records or dicts) to ``path``. Columns: the dataclass fields or
    the first dict's keys unless given; a column a row lacks is left blank. ``comment``: a first
    line ``# comment`` (what the file holds, the script that wrote it)."""
    records = [r if isinstance(r, dict) else asdict(r) for r in rows]
    if columns is None:
        columns = list(records[0]) if records else []
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("w", newline="") as f:
        if comment is not None:
            f.write(f"# {comment}\n")
        w = csv.DictWriter(f, fieldnames=list(columns), restval="")
        w.writeheader()
        for r in records:
            w.writerow({k: (f"{v:.6g}" if isinstance(v, float) else v) for k, v in r.items()})


def read_csv(path: Path) -> list[dict[str, str]]:
    """Rows of a study CSV as dicts of strings; lines starting with '#' are comments."""
    with path.open(newline="") as f:
        return list(csv.DictReader(line for line in f if not line.startswith("#")))


def print_rows(rows: Sequence[dict]) -> None:
    """Print each row as one ``key=value`` line, floats to 4 digits (a study's summary)."""
    for r in rows:
        cells = [f"{k}={v:.4g}" if isinstance(v, float) else f"{k}={v}" for k, v in r.items()]
        print(", ".join(cells))
