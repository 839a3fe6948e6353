"""What the fictitious mass costs the structure per coupling window (issue 21).

A 2D beam with the thesis ch. 5.1 light plate's span (0.305 m, clamped-clamped, 53 elements as
at H/20), driven through coupling windows the way the coupler drives it (checkpoint, then per
iteration restore + set_iterate + write forces + advance), with a load on a patch of the plate:

* ``none``: no fictitious mass (the plain structure window);
* ``lumped``: fictitious_mass 50 kg/m^2 on the window's wetted nodes;
* ``potential_flow``: factor 0.5 on the wetted patch's potential-flow operator.

Each is timed with the wetted patch fixed (the set is decided once; later windows reuse the
factorisation) and with a patch whose length changes every window (5 to 24 nodes: a new M_f and
a new factorisation every window, the worst case during a slam). Reported per window of
``--iterations`` iterations (default 6, the light plate's mean), and per iteration, in CPU
time of this process (single-threaded BLAS).

    python benchmarks/bench_fictitious_mass.py [--windows 200] [--iterations 6]

Prints a table and writes benchmarks/results/fictitious_mass.csv.
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # before numpy: no BLAS threads spinning

import argparse  # noqa: E402
import csv
import platform
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
SPAN, ELEMENTS, DT = 0.305, 53, 2.5e-4  # m; the H/20 plate's element count; window = 1 step
RHO_W = 1000.0
MEMBER = {
    "name": "plate",
    "type": "beam",
    "start": [0.0, 0.0],
    "end": [SPAN, 0.0],
    "elements": ELEMENTS,
    "bc": ["clamped", "clamped"],
    "material": {"youngs_modulus": 12e6, "density": 1040.0},
    "area": 2.5e-5,
    "second_moment": 1e-9,
    "thickness": 0.005,
    "axial": False,
}
VARIANTS = {
    "none": {},
    "lumped": {"fictitious_mass": 50.0, "fictitious_mass_nodes": "wet"},
    "potential_flow": {
        "fictitious_mass": 0.5,
        "fictitious_mass_nodes": "wet",
        "fictitious_mass_model": "potential_flow",
    },
}


def participant(variant: str):
    from mpsfem.scenario.structure import StructureSection
    from mpsfem.structure_fem.participant import StructureParticipant

    member = dict(MEMBER, **VARIANTS[variant])
    section = StructureSection.model_validate({"members": [member], "time": {"dt": DT}})
    return StructureParticipant(section, fluid_density=RHO_W)


def run(variant: str, growing: bool, windows: int, iterations: int) -> dict:
    """Time `windows` coupling windows; returns seconds per window and the set changes."""
    st = participant(variant)
    n = st.system.n_points
    first = n // 2 - 2
    st.write("forces", np.zeros((n, 2)))
    t0 = time.process_time()  # this process's CPU time: the shared machine's wall time varies
    for w in range(windows):
        # a patch of 5 nodes (fixed) or of 5 + (w mod 20) nodes (a new wet set every window)
        last = first + 5 + (w % 20 if growing else 0)
        f = np.zeros((n, 2))
        # 0.01 Pa over each node's share (N/m): small rotations, the linear beam stays valid
        f[first:last, 1] = 0.01 * SPAN / ELEMENTS
        state = st.checkpoint()
        for k in range(iterations):
            if k:
                st.restore(state)
            st.set_iterate(st.read("displacement"), DT)
            st.write("forces", f * (1.0 + 1e-3 * k))
            st.advance(DT)
    wall = time.process_time() - t0
    changes = getattr(st, "fictitious_set_changes", 0)
    return {"wall_s": wall, "set_changes": int(changes or 0)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--windows", type=int, default=200)
    ap.add_argument("--iterations", type=int, default=6)
    ap.add_argument("--out", type=Path, default=ROOT / "benchmarks/results/fictitious_mass.csv")
    args = ap.parse_args()
    for v in VARIANTS:  # warm-up: imports, scikit-fem assembly caches
        run(v, True, 3, 2)
    rows = []
    host = f"{platform.machine()}, {platform.python_version()}"
    for growing in (False, True):
        for v in VARIANTS:
            r = run(v, growing, args.windows, args.iterations)
            per_window = r["wall_s"] / args.windows * 1e3
            rows.append(
                {
                    "variant": v,
                    "wet_patch": "changing" if growing else "fixed",
                    "windows": args.windows,
                    "iterations": args.iterations,
                    "ms_per_window": per_window,
                    "ms_per_iteration": per_window / args.iterations,
                    "set_changes": r["set_changes"],
                    "host": host,
                }
            )
            print(
                f"{v:>15s} {rows[-1]['wet_patch']:>8s}: {per_window:7.2f} ms/window "
                f"({per_window / args.iterations:6.3f} ms/iteration), "
                f"{r['set_changes']} set changes",
                flush=True,
            )
    args.out.parent.mkdir(parents=True, exist_ok=True)
    with args.out.open("w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    print(f"wrote {args.out}", file=sys.stderr)


if __name__ == "__main__":
    main()
