"""Cost of recording coupling windows in the results file (results/results_file.py).

A coupled run records one /coupling row per window: time, iterations, residual and the
scheme's 15 named scalars (energies, works, wall times, sub-step counts), the keys of a real
run of scenarios/dam_break_elastic_obstacle_2d.toml. This writes ``--windows`` such rows
into a fresh file, flushing every ``--flush-every`` windows (a run flushes every
``output.flush_interval`` s of wall time and at each checkpoint), and reports the wall time per
window, best of ``--repeat``. Run it under two checkouts to compare them, e.g.

    .venv/bin/python benchmarks/bench_results_file.py --tag after
    PYTHONPATH=/path/to/old/src .venv/bin/python benchmarks/bench_results_file.py --tag before

Appends a row to benchmarks/results/results_file.csv.
"""

from __future__ import annotations

import argparse
import csv
import platform
import tempfile
import time
from pathlib import Path

import numpy as np

from mpsfem.results.results_file import ResultsFile

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "benchmarks" / "results" / "results_file.csv"
#: the named scalars of a coupled run's window record (besides time, iterations, residual)
KEYS = (
    "converged",
    "energy_imbalance",
    "fluid_substeps",
    "interface_work_error",
    "residual_abs",
    "structure_energy",
    "structure_substeps",
    "wall_acceleration",
    "wall_fluid",
    "wall_mapping",
    "wall_structure",
    "window",
    "work_fluid",
    "work_structure",
    "work_structure_total",
)


def one_run(windows: int, flush_every: int, folder: Path) -> float:
    """Seconds per window of `windows` appended records with a flush every `flush_every`."""
    rng = np.random.default_rng(1)
    values = rng.random((windows, len(KEYS)))
    rf = ResultsFile.create(folder / "bench.h5", "title = 'bench'")
    tic = time.perf_counter()
    for k in range(windows):
        rf.append_coupling(2.5e-4 * (k + 1), 2, 1e-4, **dict(zip(KEYS, values[k], strict=True)))
        if (k + 1) % flush_every == 0:
            rf.flush()
    rf.close("finished")
    return (time.perf_counter() - tic) / windows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--windows", type=int, default=640)
    ap.add_argument("--flush-every", type=int, default=160)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--tag", default="")
    ap.add_argument("--out", type=Path, default=OUT)
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        best = min(one_run(args.windows, args.flush_every, Path(tmp)) for _ in range(args.repeat))
    row = {
        "tag": args.tag,
        "windows": args.windows,
        "flush_every": args.flush_every,
        "us_per_window": round(best * 1e6, 1),
        "machine": platform.node(),
    }
    print(f"{args.tag or 'run'}: {row['us_per_window']} us per window "
          f"({args.windows} windows, flush every {args.flush_every}, best of {args.repeat})")  # fmt: skip
    new = not args.out.exists()
    with args.out.open("a", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(row))
        if new:
            w.writeheader()
        w.writerow(row)


if __name__ == "__main__":
    main()
