"""Prescribed loads of standalone runs: time functions and their load vectors.

A prescribed load is a fixed spatial load vector times a scalar time function f(t):

* ``step``: 0 before `start`, 1 from `start` on;
* ``ramp``: linear from 0 at `start` to 1 at `start + duration`, then 1;
* ``harmonic``: sin(2 pi frequency (t - start) + phase) from `start` on, 0 before;
* ``table``: linear interpolation in (t, f) pairs (inline or a CSV file), held at the end values.

:class:`PrescribedLoads` stacks the load vectors as the columns of one matrix so that the load at
time t is one mat-vec with the vector of time-function values.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path

import numpy as np

__all__ = ["time_function", "read_table_csv", "PrescribedLoads"]


def read_table_csv(path: str | Path) -> np.ndarray:
    """Read a two-column CSV table (t, f); '#' comments and one non-numeric header are skipped."""
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"load table {path} not found")
    rows = []
    for lineno, line in enumerate(path.read_text().splitlines(), start=1):
        line = line.split("#", 1)[0].strip()
        if not line:
            continue
        cells = [c.strip() for c in line.split(",")]
        try:
            values = [float(c) for c in cells]
        except ValueError:
            if rows:
                raise ValueError(
                    f"load table {path}, line {lineno}: not numbers: {line!r}"
                ) from None
            continue  # a header before the first data row
        if len(values) != 2:
            raise ValueError(
                f"load table {path}, line {lineno}: {len(values)} values ({line!r}); "
                "each row must be two numbers: t, f"
            )
        rows.append(values)
    data = np.array(rows, dtype=float) if rows else np.zeros((0, 2))
    if data.shape[1] != 2 or data.shape[0] < 1:
        raise ValueError(f"load table {path}: need two columns t, f; got shape {data.shape}")
    if np.any(np.diff(data[:, 0]) <= 0):
        raise ValueError(f"load table {path}: times must be strictly increasing")
    return data


def time_function(cfg, base_dir: str | Path | None = None) -> Callable[[float], float]:
    """The scalar time function f(t) described by a scenario time-function table."""
    kind = cfg.kind
    if kind == "step":
        t0 = cfg.start
        return lambda t: 1.0 if t >= t0 else 0.0
    if kind == "ramp":
        t0, T = cfg.start, cfg.duration
        return lambda t: min(1.0, max(0.0, (t - t0) / T))
    if kind == "harmonic":
        t0, w, ph = cfg.start, 2.0 * math.pi * cfg.frequency, cfg.phase
        return lambda t: math.sin(w * (t - t0) + ph) if t >= t0 else 0.0
    if kind == "table":
        if cfg.points is not None:
            data = np.asarray(cfg.points, dtype=float)
        else:
            p = Path(cfg.file)
            if not p.is_absolute() and base_dir is not None:
                p = Path(base_dir) / p
            data = read_table_csv(p)
        ts, fs = data[:, 0].copy(), data[:, 1].copy()
        return lambda t: float(np.interp(t, ts, fs))
    raise ValueError(f"unknown time function kind {kind!r}; allowed: step, ramp, harmonic, table")


class PrescribedLoads:
    """Sum of load vectors times time functions: ``F(t) = sum_k f_k(t) F_k``."""

    def __init__(self, n: int) -> None:
        self.n = n
        self._vectors: list[np.ndarray] = []
        self._functions: list[Callable[[float], float]] = []
        self._matrix = np.zeros((n, 0))

    def add(self, vector: np.ndarray, function: Callable[[float], float]) -> None:
        vector = np.asarray(vector, dtype=float)
        if vector.shape != (self.n,):
            raise ValueError(f"load vector of shape {vector.shape}, expected ({self.n},)")
        self._vectors.append(vector)
        self._functions.append(function)
        self._matrix = np.column_stack(self._vectors)

    def __len__(self) -> int:
        return len(self._vectors)

    def __call__(self, t: float) -> np.ndarray:
        if not self._vectors:
            return np.zeros(self.n)
        f = np.array([fn(t) for fn in self._functions])
        return self._matrix @ f
