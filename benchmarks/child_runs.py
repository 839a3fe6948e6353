"""Shared plumbing of the fluid benchmarks: the command line, one resolution per child process
(so that peak RSS is measured per run), the peak-memory slope between the two largest runs, and
the CSV."""

from __future__ import annotations

import argparse
import csv
import json
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path

import numpy as np


def run_child(
    script: str, spacing: float, end_time: float, threads: int, overrides: list[str]
) -> dict:
    """Run ``script --child spacing`` in a new interpreter; the dict it prints last as JSON."""
    cmd = [sys.executable, script, "--child", str(spacing)]
    cmd += ["--end-time", str(end_time), "--threads", str(threads)]
    for o in overrides:
        cmd += ["--set", o]
    out = subprocess.run(cmd, check=True, capture_output=True, text=True).stdout
    return json.loads(out.strip().splitlines()[-1])


def memory_slope(rows: list[dict]) -> float | None:
    """Peak memory per particle (B): the slope of peak RSS (KiB) against ``all_particles``
    between the two largest runs, which excludes the interpreter's baseline. Stored in every
    row as ``bytes_per_particle_slope`` and printed; None with fewer than two runs."""
    if len(rows) < 2:
        return None
    a, b = rows[-2], rows[-1]
    slope = (
        (b["peak_rss_kib"] - a["peak_rss_kib"]) * 1024 / (b["all_particles"] - a["all_particles"])
    )
    for r in rows:
        r["bytes_per_particle_slope"] = slope
    print(
        f"peak memory per particle (slope {a['all_particles']} -> {b['all_particles']}): {slope:.0f} B"
    )
    return slope


def stage_columns(solver) -> dict:
    """The fluid solver's accumulated stage times (s) and its mean pressure-solve iterations per
    step, as benchmark columns."""
    tm = solver.times
    return {
        "neighbours_s": tm.neighbours,
        "explicit_s": tm.explicit,
        "assembly_s": tm.assembly,
        "solve_s": tm.solve,
        "iterations_per_step": float(np.mean(tm.iterations)),
    }


def stage_text(row: dict, digits: int = 1) -> str:
    """The :func:`stage_columns` of a row as printed: 'nb .. expl .. asm .. solve .. s'."""
    return (
        f"nb {row['neighbours_s']:.{digits}f} expl {row['explicit_s']:.{digits}f} "
        f"asm {row['assembly_s']:.{digits}f} solve {row['solve_s']:.{digits}f} s"
    )


def write_rows(rows: list[dict], path: Path) -> None:
    """The rows as a CSV with the first row's keys as header."""
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0].keys()))
        w.writeheader()
        w.writerows(rows)
    print(f"wrote {path}")


def benchmark_main(
    description: str,
    script: str,
    one_run: Callable[[float, float, int, list[str]], dict],
    spacings: dict[str, float],
    describe: Callable[[dict], str],
    end_time: float,
    threads: int,
    out: Path,
) -> None:
    """The benchmark's command line: ``--sizes`` (keys of ``spacings``, comma-separated),
    ``--end-time`` (s), ``--threads``, ``--out``, ``--set key=value`` (scenario overrides,
    repeatable); each size runs ``one_run(spacing, end_time, threads, overrides)`` in a child
    process, prints ``describe(row)``, then the memory slope; the rows go to the CSV, with the
    overrides in a column."""
    ap = argparse.ArgumentParser(description=description)
    ap.add_argument("--sizes", default=",".join(spacings))
    ap.add_argument("--end-time", type=float, default=end_time)
    ap.add_argument("--threads", type=int, default=threads)
    ap.add_argument("--child", type=float, help=argparse.SUPPRESS)
    ap.add_argument("--out", type=Path, default=out)
    ap.add_argument(
        "--set", action="append", default=[], metavar="KEY=VALUE", help="scenario override"
    )
    args = ap.parse_args()
    if args.child is not None:
        row = one_run(args.child, args.end_time, args.threads, args.set)
        print(json.dumps(row | {"overrides": " ".join(args.set)}))
        return
    rows = []
    for size in args.sizes.split(","):
        if size not in spacings:
            ap.error(f"--sizes: {size!r} is not one of {', '.join(spacings)}")
        rows.append(run_child(script, spacings[size], args.end_time, args.threads, args.set))
        print(describe(rows[-1]), flush=True)
    memory_slope(rows)
    write_rows(rows, args.out)
