"""Shared plumbing of the fluid benchmarks: one resolution per child process (so that peak RSS
is measured per run), the peak-memory slope between the two largest runs, and the CSV."""

from __future__ import annotations

import csv
import json
import subprocess
import sys
from pathlib import Path


def run_child(script: str, spacing: float, end_time: float, threads: int) -> dict:
    """Run ``script --child spacing`` in a new interpreter; the dict it prints last as JSON."""
    cmd = [sys.executable, script, "--child", str(spacing)]
    cmd += ["--end-time", str(end_time), "--threads", str(threads)]
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


def write_rows(rows: list[dict], path: Path) -> None:
    """The rows as a CSV with the first row's keys as header."""
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0].keys()))
        w.writeheader()
        w.writerows(rows)
    print(f"wrote {path}")
