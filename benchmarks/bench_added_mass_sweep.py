"""Added-mass stress sweep of the implicit coupling's accelerators on the mock problem.

    .venv/bin/python benchmarks/bench_added_mass_sweep.py [--windows N] [--quick]

The mock (``coupler/mock.py``): a spring-mass member (11 nodes) and an added-mass fluid on both
faces, F_i = -m_i a_i; mu = added mass / structure mass. A very light member in water has a
large mu: the issue's "mass ratio down to 1e-4" read as structure / added mass is mu = 1e4. The
window's fixed-point map has eigenvalues from about -0.19 mu to -1.24 mu, so plain iteration
diverges above mu of about 2 and every unexplored direction grows by up to 1.24 mu per
iteration.

One factor at a time, around mu = 10 and window T = 1 ms (the structure's time step; the fluid
sub-cycles at 0.4 ms):

* mu from 1e-4 to 1e4 (nine decades) at T = 1 ms;
* T = 0.25, 1, 4 ms (a 4 ms window sub-cycles the structure too) at mu = 10 and at mu = 1e4.

Accelerators: constant (0.5), Aitken, IQN-ILS (its defaults: displacement only, complement
relaxation 1 as preCICE; reuse 0; displacement + velocity with each preconditioner; "auto"
complement relaxation) and IQN-IMVJ (its defaults: displacement + velocity, "value" scaling,
"auto" complement relaxation, RS-SVD; each of those changed alone; the other restart modes).
Labels: "d" displacement only, "d+v" displacement and velocity, "auto" complement relaxation.

Every case runs ``--windows`` windows (default 100) with rtol 1e-3 (relative to the
displacement), max_iterations 50, ``on_divergence = "stop"``, for each accelerator below. A run
either converges every window or stops with a named ``CouplingError`` (which window, why);
non-finite data always stop (``check_finite``), so no NaN is ever accepted. Reported: status,
iterations per window (mean, max) over the windows done, the largest accepted residual, wall
time. Prints a table and writes benchmarks/results/added_mass_sweep.csv.
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # before numpy: a shared 2-core machine

import argparse  # noqa: E402
import csv  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "src"))

from mpsfem.coupler import mock  # noqa: E402
from mpsfem.coupler.coupling_scheme import create_scheme  # noqa: E402
from mpsfem.coupler.errors import CouplingError  # noqa: E402
from mpsfem.scenario.coupling import CouplingSection  # noqa: E402

DV = ["displacement", "velocity"]
#: label -> [coupling.acceleration] table
ACCELERATORS: dict[str, dict] = {
    "constant 0.5": {"kind": "constant", "relaxation": 0.5},
    "aitken": {"kind": "aitken"},
    "iqn-ils": {"kind": "iqn-ils"},
    "iqn-ils reuse 0": {"kind": "iqn-ils", "reuse_windows": 0},
    "iqn-ils d+v none": {"kind": "iqn-ils", "data": DV, "preconditioner": "none"},
    "iqn-ils d+v value": {"kind": "iqn-ils", "data": DV, "preconditioner": "value"},
    "iqn-ils d+v residual_sum": {"kind": "iqn-ils", "data": DV, "preconditioner": "residual_sum"},
    "iqn-ils auto": {"kind": "iqn-ils", "complement_relaxation": "auto"},
    "iqn-ils d+v value auto": {"kind": "iqn-ils", "data": DV, "preconditioner": "value", "complement_relaxation": "auto"},
    "iqn-imvj d": {"kind": "iqn-imvj", "data": ["displacement"], "complement_relaxation": 1.0},
    "iqn-imvj d+v none": {"kind": "iqn-imvj", "preconditioner": "none", "complement_relaxation": 1.0},
    "iqn-imvj d+v value": {"kind": "iqn-imvj", "preconditioner": "value", "complement_relaxation": 1.0},
    "iqn-imvj d+v residual_sum": {"kind": "iqn-imvj", "preconditioner": "residual_sum", "complement_relaxation": 1.0},
    "iqn-imvj d auto": {"kind": "iqn-imvj", "data": ["displacement"]},
    "iqn-imvj (defaults)": {"kind": "iqn-imvj"},
    "iqn-imvj no-restart": {"kind": "iqn-imvj", "restart": "no-restart"},
    "iqn-imvj RS-LS": {"kind": "iqn-imvj", "restart": "RS-LS"},
    "iqn-imvj RS-0": {"kind": "iqn-imvj", "restart": "RS-0"},
}  # fmt: skip

MU_SWEEP = [1e-4, 1e-3, 1e-2, 0.1, 1.0, 10.0, 1e2, 1e3, 1e4]
WINDOWS = [2.5e-4, 1e-3, 4e-3]


def run_case(mu: float, window: float, acc: dict, n_windows: int) -> dict:
    """One coupled run; never raises a CouplingError (it is the result)."""
    fluid, structure = mock.pair(mu)
    config = CouplingSection.model_validate(
        {
            "scheme": "implicit",
            "window": window,
            "mapping": {"kind": "shape-function"},
            "acceleration": acc,
            "convergence": {
                "relative_tolerance": 1e-3,
                "max_iterations": 50,
                "on_divergence": "stop",
            },
        }
    )
    scheme = create_scheme(fluid, structure, config)
    status = "converged"
    trace: list[np.ndarray] = []
    t0 = time.perf_counter()
    try:
        scheme.run(n_windows * window, on_window=lambda rec: trace.append(structure.u.copy()))
    except CouplingError as exc:
        status = f"{type(exc).__name__} @ window {scheme.index}"
    wall = time.perf_counter() - t0
    # is the accepted solution right? the monolithic one where it is known (windows of one
    # structure step), and always the bound |u| <= 2 |u_static| of an undamped step response
    u = np.array(trace) if trace else np.zeros((0, structure.n))
    bound = (
        float(np.abs(u).max() / (2.0 * np.abs(mock.static_deflection(mu)).max())) if trace else 0.0
    )
    error = float("nan")
    if trace and window <= structure.dt:
        ref = mock.monolithic_reference(mu, len(trace), window)
        error = float(
            np.sqrt(((u - ref) ** 2).mean(axis=1)).max() / np.sqrt((ref**2).mean(axis=1)).max()
        )
    if status == "converged" and not (bound <= 1.05 and not error > 0.1):
        status = "WRONG: converged windows, wrong solution"
    h = scheme.history
    it = h.column("iterations") if len(h) else np.zeros(0)
    res = h.column("residual") if len(h) else np.zeros(0)
    if len(h) and not (np.isfinite(res).all() and np.isfinite(scheme.d).all()):
        status += " NON-FINITE"  # must never happen: check_finite stops first
    return {
        "status": status,
        "windows_done": len(h),
        "it_mean": float(it.mean()) if it.size else float("nan"),
        "it_max": int(it.max()) if it.size else 0,
        "residual_max": float(res.max()) if res.size else float("nan"),
        "error_vs_monolithic": error,
        "max_disp_over_bound": bound,
        "wall_s": wall,
    }


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--windows", type=int, default=100)
    p.add_argument("--quick", action="store_true", help="mu sweep only, 20 windows")
    p.add_argument("--out", default=str(ROOT / "benchmarks" / "results" / "added_mass_sweep.csv"))
    args = p.parse_args(argv)
    n_windows = 20 if args.quick else args.windows
    cases = [("mu", mu, 1e-3) for mu in MU_SWEEP]
    if not args.quick:
        cases += [("window", mu, T) for mu in (10.0, 1e4) for T in WINDOWS if T != 1e-3]
    rows = []
    t_all = time.perf_counter()
    for sweep, mu, T in cases:
        for label, acc in ACCELERATORS.items():
            r = run_case(mu, T, acc, n_windows)
            ok = r["status"] == "converged" and r["it_mean"] <= 5.0
            rows.append(
                {"sweep": sweep, "mu": mu, "window_s": T, "accelerator": label, **r,
                 "target_met": ok}
            )  # fmt: skip
            print(
                f"{sweep:6} mu={mu:<8.0e} T={T:<7.2e} {label:26} {r['status']:38} "
                f"{r['it_mean']:6.2f} {r['it_max']:3d}  {r['wall_s']:6.2f} s",
                flush=True,
            )
    print(f"\ntotal {time.perf_counter() - t_all:.1f} s; {n_windows} windows per run, rtol 1e-3")
    print("\niterations per window, mean / max (T = 1 ms); x = stopped (see the CSV)")
    labels = list(ACCELERATORS)
    print(f"{'accelerator':26}" + "".join(f"{mu:>11.0e}" for mu in MU_SWEEP))
    for label in labels:
        cells = []
        for mu in MU_SWEEP:
            r = next(x for x in rows if x["sweep"] == "mu" and x["mu"] == mu
                     and x["accelerator"] == label)  # fmt: skip
            cell = f"{r['it_mean']:.2f}/{r['it_max']}"
            cells.append(
                f"{cell if r['status'] == 'converged' else 'x' + str(r['windows_done']):>11}"
            )
        print(f"{label:26}" + "".join(cells))
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    with out.open("w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    print(f"\nwrote {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
