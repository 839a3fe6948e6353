"""δ-SPH peak memory per particle, for ``mpsfem validate``'s estimate (scenario_report.py).

The still-water tank of bench_delta_sph.py (δ-SPHC, h = 1.3 l0, RK4) at two or more depths in
l0 (default 90, 180 and 240: 18k, 68k and 120k particles), one child process each: a small tank
is stepped once (compilation or the cache's load), the solver is built and ``--steps`` steps are
taken, then the child prints its peak RSS. Bytes per particle: the slope of
peak RSS against all particles between the two largest runs (the interpreter's and the
compiler's share cancels), as benchmarks/child_runs.py takes it for MPS.

Writes benchmarks/results/delta_sph_memory.csv.

    python benchmarks/bench_delta_sph_memory.py [--depths 90,180,240] [--steps 2]
"""

from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "validation"))
sys.path.insert(0, str(ROOT / "benchmarks"))
from results_csv import write_csv  # noqa: E402

RESULTS = ROOT / "benchmarks" / "results"


def child(n_depth: int, steps: int) -> dict:
    """Build the tank at d / l0 = ``n_depth``, take ``steps`` steps; counts and peak RSS."""
    import numba
    from bench_delta_sph import tank

    numba.set_num_threads(1)
    warm = tank(10, 1.3)  # compile (or load the cache) on a small tank first
    warm.step(warm.dt_next)
    s = tank(n_depth, 1.3)
    for _ in range(steps):
        s.step(s.dt_next)
    return {
        "depth_l0": n_depth,
        "all_particles": s.n,
        "fluid_particles": s.n_fluid,
        "integrator": s.sph.integrator,
        "steps": steps,
        "peak_rss_kib": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss,
    }


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--depths", default="90,180,240")
    ap.add_argument("--steps", type=int, default=2)
    ap.add_argument("--child", type=int, help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.child is not None:
        print(json.dumps(child(args.child, args.steps)))
        return 0
    rows = []
    for n_depth in (int(x) for x in args.depths.split(",")):
        cmd = [sys.executable, __file__, "--child", str(n_depth), "--steps", str(args.steps)]
        out = subprocess.run(cmd, check=True, capture_output=True, text=True).stdout
        rows.append(json.loads(out.strip().splitlines()[-1]))
        r = rows[-1]
        print(f"d/l0 {n_depth}: {r['all_particles']} particles, peak RSS {r['peak_rss_kib']} KiB")
    if len(rows) >= 2:
        a, b = rows[-2], rows[-1]
        slope = (
            (b["peak_rss_kib"] - a["peak_rss_kib"])
            * 1024
            / (b["all_particles"] - a["all_particles"])
        )
        for r in rows:
            r["bytes_per_particle_slope"] = slope
        print(f"peak memory per particle (slope between the two largest): {slope:.0f} B")
    write_csv(rows, RESULTS / "delta_sph_memory.csv",
              comment="δ-SPHC peak memory, still-water tank, h = 1.3 l0 (benchmarks/bench_delta_sph_memory.py)")  # fmt: skip
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
