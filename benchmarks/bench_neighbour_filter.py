"""Cost of the thin-member neighbour filters (fluid_mps/thin_member.py, thin_plate.py).

Every MPS step and every δ-SPH right-hand side of a coupled run filters the neighbour list
so that nothing interacts through a member. This builds the fluid participant of a scenario,
takes its neighbour list at t = 0 and times the filter's two kernels on it: the side
classification of every particle and the pair marking (``mark_pairs`` / ``mark_plate_pairs``,
the loop over the pairs of every row near a member), each the least of ``--repeat`` blocks of
``--calls`` calls, one thread. Cases: the 3D hydrostatic plate (scenarios/hydrostatic_plate_3d.toml,
a plate under the whole column) and the 2D elastic obstacle
(scenarios/dam_break_elastic_obstacle_2d.toml). A checksum of the kept pairs lets two
checkouts be compared:

    taskset -c 1 .venv/bin/python benchmarks/bench_neighbour_filter.py --tag after
    PYTHONPATH=/path/to/old/src taskset -c 1 .venv/bin/python benchmarks/bench_neighbour_filter.py --tag before

Appends rows to benchmarks/results/neighbour_filter.csv.
"""

from __future__ import annotations

import argparse
import csv
import time
from pathlib import Path

import numba
import numpy as np

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "benchmarks" / "results" / "neighbour_filter.csv"
CASES = {
    "plate_3d": ROOT / "scenarios" / "hydrostatic_plate_3d.toml",
    "obstacle_2d": ROOT / "scenarios" / "dam_break_elastic_obstacle_2d.toml",
}


def least(fn, calls: int, repeat: int) -> float:
    """Least seconds per call of ``fn`` over ``repeat`` blocks of ``calls`` calls."""
    fn()
    best = float("inf")
    for _ in range(repeat):
        tic = time.perf_counter()
        for _ in range(calls):
            fn()
        best = min(best, (time.perf_counter() - tic) / calls)
    return best


def bench(case: str, calls: int, repeat: int) -> dict:
    from mpsfem.fluid_mps.participant import FluidParticipant
    from mpsfem.scenario.loader import load_scenario
    from mpsfem.structure_fem.participant import StructureParticipant

    sc = load_scenario(CASES[case]).scenario
    st = StructureParticipant(sc.structure)
    names = [m.name for m in sc.structure.members]
    fp = FluidParticipant(sc.fluid, st.interface(), member_names=names)
    s, f = fp.solver, fp.filter
    nb = s.search.build(s.pos)
    geometry = f._geometry(s.pos)
    reach = nb.radius + f._extra + f.surface.l0
    keep = np.zeros(nb.indices.shape[0] + 16, np.int8)

    def classify():
        f._classify(s.pos, *geometry, reach, f._side)

    def mark():
        return f._mark(s.pos, s.kind, nb.indptr, nb.indices, f.member_of, f.side_of, f.half,
                       f._side, *geometry, keep, f._drops)  # fmt: skip

    t_classify = least(classify, calls, repeat)
    t_mark = least(mark, calls, repeat)
    dropped = int(mark())
    involved = (f._side != 0).any(axis=1) | (f.member_of >= 0)
    rows = np.flatnonzero(involved)
    pairs = int((nb.indptr[rows + 1] - nb.indptr[rows]).sum())
    k = keep[: nb.indices.shape[0]].astype(np.int64)
    checksum = int((k * np.arange(k.size, dtype=np.int64)).sum() % 1_000_003)
    return {
        "case": case,
        "particles": s.n,
        "rows_near_members": int(involved.sum()),
        "pairs_in_them": pairs,
        "classify_ms": round(1e3 * t_classify, 3),
        "mark_ms": round(1e3 * t_mark, 3),
        "mark_ns_per_pair": round(1e9 * t_mark / max(pairs, 1), 2),
        "pairs_dropped": dropped,
        "keep_checksum": checksum,
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--calls", type=int, default=5)
    ap.add_argument("--repeat", type=int, default=10)
    ap.add_argument("--tag", default="")
    ap.add_argument("--out", type=Path, default=OUT)
    args = ap.parse_args()
    numba.set_num_threads(1)
    rows = []
    for case in CASES:
        r = {"tag": args.tag, **bench(case, args.calls, args.repeat)}
        rows.append(r)
        print(f"{args.tag or 'run'} {case}: {r['particles']} particles, {r['rows_near_members']} "
              f"rows near members ({r['pairs_in_them']} pairs): classify {r['classify_ms']} ms, "
              f"mark {r['mark_ms']} ms ({r['mark_ns_per_pair']} ns a pair), "
              f"{r['pairs_dropped']} dropped, checksum {r['keep_checksum']}")  # fmt: skip
    new = not args.out.exists()
    with args.out.open("a", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        if new:
            w.writeheader()
        w.writerows(rows)


if __name__ == "__main__":
    main()
