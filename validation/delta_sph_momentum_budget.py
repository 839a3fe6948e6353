"""The δ-SPH fluid's momentum budget on the Koshizuka-Oka dam break (issue 23), beside MPS's.

Case: validation/results/delta_sph_dam_break.toml (scenarios/dam_break_2d.toml's geometry under
δ-SPHC, RK4, written by validation/delta_sph_dam_break.py) at l0 = L/40 to 0.4 s with
``fluid.momentum_budget = true`` (one ``mpsfem run`` subprocess, resumable). Per window, as
validation/momentum_budget.py takes MPS's (collapse 0-0.2 s, impact 0.2-0.4 s), from
``/momentum_budget`` (impulses, N s/m):

* ``residual_external`` = dP - G + sum_b J_b with J_b the *reported* impulse on patch b (the
  pressure integral, thesis eq. 2-51, at each step's end: what a force probe reads), per
  component, relative to sum_b |J_b|; MPS's default gave -44 % / 6.8 % on the impact window;
* ``closure`` = dP - G - I + sum_b E_b with E_b the pair *exchange* and I the internal imbalance:
  the ledger's own closure (round-off by construction of the split,
  tests/fluid_sph/test_delta_sph_budget.py).

Writes validation/results/delta_sph_momentum_budget.csv and prints the table (docs/fluid_sph.md,
"Momentum budget").

    python validation/delta_sph_momentum_budget.py [--threads 1] [--analyse-only] [--retry-failed]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import h5py
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import case_runner  # noqa: E402
from results_csv import write_csv  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "validation" / "results"
SCENARIO = RESULTS / "delta_sph_dam_break.toml"
OUT = RESULTS / "delta_sph_momentum_budget_L40.h5"
CSV = RESULTS / "delta_sph_momentum_budget.csv"
OVERRIDES = ["fluid.spacing=0.00365", "run.end_time=0.4", "fluid.momentum_budget=true"]
WINDOWS = [("collapse", 0.0, 0.2), ("impact", 0.2, 0.4)]  # as validation/momentum_budget.py


def window_row(path: Path, label: str, t0: float, t1: float) -> dict:
    """The budget rows with t0 < time <= t1 summed, and the residuals of the window."""
    with h5py.File(path, "r") as h5:
        g = h5["momentum_budget"]
        t = g["time"][:]
        sel = (t > t0) & (t <= t1)
        b = {k: g[k][sel].sum(axis=0) for k in g if k != "time"}
        wall = float(h5.attrs.get("wall_time", np.nan)) if "wall_time" in h5.attrs else np.nan
    rep = b["patch_reported"].sum(axis=0)
    exch = b["patch_exchange"].sum(axis=0)
    scale = np.abs(b["patch_reported"]).sum(axis=0)
    internal = b["internal_pressure"] + b["internal_viscous"]
    res_ext = b["momentum_change"] - b["gravity"] + rep  # dP - G + sum_b J_b
    closure = b["momentum_change"] - b["gravity"] - internal + exch  # dP - G - I + sum_b E_b
    row = {"window": label, "t0_s": t0, "t1_s": t1, "steps": int(sel.sum()), "wall_s": wall}
    for a, ax in enumerate("xy"):
        row[f"momentum_change_{ax}"] = float(b["momentum_change"][a])
        row[f"gravity_{ax}"] = float(b["gravity"][a])
        row[f"reported_{ax}"] = float(rep[a])
        row[f"exchange_{ax}"] = float(exch[a])
        row[f"internal_{ax}"] = float(internal[a])
        row[f"residual_external_{ax}"] = float(res_ext[a])
        row[f"residual_external_rel_{ax}"] = float(res_ext[a] / scale[a])
        row[f"closure_rel_{ax}"] = float(closure[a] / np.abs(b["patch_exchange"][:, a]).sum())
    return row


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    case_runner.add_run_options(ap)
    args = ap.parse_args()
    if not SCENARIO.is_file():
        print(f"{SCENARIO} is missing: run validation/delta_sph_dam_break.py first")
        return 1
    status = case_runner.case_status(
        SCENARIO, OUT, OVERRIDES, args.threads, args.analyse_only, args.retry_failed, "δ-SPH"
    )
    if status != "finished":
        print(f"δ-SPH dam break L/40: {status}, not analysed")
        return 1
    rows = [window_row(OUT, *w) for w in WINDOWS]
    write_csv(
        rows,
        CSV,
        comment="δ-SPH dam break L/40 momentum budget per window, impulses N s/m "
        "(validation/delta_sph_momentum_budget.py)",
    )
    for r in rows:
        print(
            f"{r['window']:9s} residual_external x {100 * r['residual_external_rel_x']:7.2f} % "
            f"y {100 * r['residual_external_rel_y']:7.2f} %   closure x "
            f"{r['closure_rel_x']:.1e} y {r['closure_rel_y']:.1e}"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
