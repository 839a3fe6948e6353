"""The CSV files of the validation studies: one row per dataclass record, floats to 6 digits."""

from __future__ import annotations

import csv
from collections.abc import Sequence
from dataclasses import asdict, fields
from pathlib import Path


def write_csv(rows: Sequence, path: Path, columns: Sequence[str] | None = None) -> None:
    """Write dataclass ``rows`` to ``path`` (columns: the dataclass fields unless given)."""
    if columns is None:
        columns = [f.name for f in fields(rows[0])] if rows else []
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(columns))
        w.writeheader()
        for r in rows:
            w.writerow(
                {k: (f"{v:.6g}" if isinstance(v, float) else v) for k, v in asdict(r).items()}
            )


def read_csv(path: Path) -> list[dict[str, str]]:
    """Rows of a study CSV as dicts of strings; lines starting with '#' are comments."""
    with path.open(newline="") as f:
        return list(csv.DictReader(line for line in f if not line.startswith("#")))
