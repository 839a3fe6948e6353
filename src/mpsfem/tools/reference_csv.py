"""Reference curves (measurements, published results) read from a small CSV file.

Accepted format (``mpsfem plot --reference``):

* one row per sample: ``time, value[, value ...]``; time in s, values in the SI unit of the series
  they are compared with (m, Pa, N or N/m in 2D, J);
* fields separated by commas; a file without any comma is split on whitespace (tabs, spaces);
* lines that are empty or start with ``#`` are skipped (comments);
* optionally one header line before the first data row (any of its fields is not a number): the
  names of the columns; value columns named like the components of the series (``ux``, ``uy``,
  ``fx`` ...) are matched to them by name;
* every data row has the same number of fields; ``nan`` marks a missing value.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from mpsfem.tools import REFERENCE_FORMAT, ToolError

FORMAT_HELP = REFERENCE_FORMAT


@dataclass
class ReferenceCurve:
    """Samples of a reference curve: ``time`` (T,) in s, ``values`` (T, K)."""

    path: Path
    time: np.ndarray
    values: np.ndarray
    names: list[str] | None  # value-column names from the header line, if there was one

    @property
    def label(self) -> str:
        return self.path.name


def _number(field: str) -> float | None:
    try:
        return float(field)
    except ValueError:
        return None


def read_reference_csv(path: str | Path) -> ReferenceCurve:
    """Read the CSV at ``path`` (format in the module docstring); errors name file, line and
    what was expected."""
    path = Path(path)
    if not path.is_file():
        raise ToolError(f"reference file {str(path)!r} does not exist")
    try:
        text = path.read_text(encoding="utf-8-sig")
    except UnicodeDecodeError as exc:
        raise ToolError(f"{path}: not a text file ({exc.reason} at byte {exc.start})") from None
    lines = [
        (no, line.strip())
        for no, line in enumerate(text.splitlines(), start=1)
        if line.strip() and not line.lstrip().startswith("#")
    ]
    if not lines:
        raise ToolError(f"{path}: no data rows; expected {FORMAT_HELP}")
    comma = "," in text

    def split(line: str) -> list[str]:
        return [f.strip() for f in line.split(",")] if comma else line.split()

    names: list[str] | None = None
    first_no, first = lines[0]
    fields = split(first)
    if any(_number(f) is None for f in fields):
        names = fields[1:]
        header_no = first_no
        lines = lines[1:]
        if not lines:
            raise ToolError(f"{path}: only a header line (line {header_no}), no data rows")
    n_fields: int | None = len(names) + 1 if names is not None else None
    if n_fields is not None and n_fields < 2:
        raise ToolError(
            f"{path} line {header_no}: header {first!r} names {n_fields} column; expected at "
            f"least 2 (time, value): {FORMAT_HELP}"
        )
    rows: list[list[float]] = []
    for no, line in lines:
        fields = split(line)
        if n_fields is None:
            n_fields = len(fields)
            if n_fields < 2:
                raise ToolError(
                    f"{path} line {no}: {line!r} has {n_fields} field; expected at least 2 "
                    f"(time, value): {FORMAT_HELP}"
                )
        if len(fields) != n_fields:
            where = "the header" if names is not None else "the first data row"
            raise ToolError(
                f"{path} line {no}: {line!r} has {len(fields)} fields; expected {n_fields} "
                f"(time and {n_fields - 1} value(s), as in {where})"
            )
        row = []
        for col, f in enumerate(fields):
            x = _number(f)
            if x is None:
                what = "time (s)" if col == 0 else f"value column {col}"
                raise ToolError(f"{path} line {no}: field {col + 1} ({what}) {f!r} is not a number")
            if col == 0 and not math.isfinite(x):
                raise ToolError(f"{path} line {no}: time {f!r} must be a finite number")
            row.append(x)
        rows.append(row)
    data = np.asarray(rows, dtype=np.float64)
    return ReferenceCurve(path, data[:, 0], data[:, 1:], names)
