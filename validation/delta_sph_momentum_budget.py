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

Two cases, the same fluid run: the walls' force reported as the pressure integral (the default,
``boundary_force`` = pressure_and_contact) and as the pair exchange averaged over each step with
RK4's weights (``fluid.boundary_force = "momentum_exchange"``). ``--models`` picks the cases to
run; rows of the others are read from their results files or kept from the CSV.

Writes validation/results/delta_sph_momentum_budget.csv and prints the table (docs/fluid_sph.md,
"Momentum budget").

    python validation/delta_sph_momentum_budget.py [--threads 1] [--analyse-only] [--retry-failed]
        [--models pressure_and_contact momentum_exchange]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import h5py
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import case_runner  # noqa: E402
from results_csv import read_csv, write_csv  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "validation" / "results"
SCENARIO = RESULTS / "delta_sph_dam_break.toml"
CSV = RESULTS / "delta_sph_momentum_budget.csv"
OVERRIDES = ["fluid.spacing=0.00365", "run.end_time=0.4", "fluid.momentum_budget=true"]
#: the walls' reported force -> (results file, extra overrides)
MODELS = {
    "pressure_and_contact": (RESULTS / "delta_sph_momentum_budget_L40.h5", []),
    "momentum_exchange": (
        RESULTS / "delta_sph_momentum_budget_L40_exchange.h5",
        ['fluid.boundary_force="momentum_exchange"'],
    ),
}
WINDOWS = [("collapse", 0.0, 0.2), ("impact", 0.2, 0.4)]  # as validation/momentum_budget.py


def window_row(path: Path, model: str, label: str, t0: float, t1: float) -> dict:
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
    row = {"boundary_force": model, **row}
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
    ap.add_argument("--models", nargs="+", choices=list(MODELS), default=list(MODELS))
    args = ap.parse_args()
    if not SCENARIO.is_file():
        print(f"{SCENARIO} is missing: run validation/delta_sph_dam_break.py first")
        return 1
    old = read_csv(CSV) if CSV.is_file() else []
    rows = []
    for model, (out, extra) in MODELS.items():
        status = case_runner.case_status(
            SCENARIO,
            out,
            [*OVERRIDES, *extra],
            args.threads,
            args.analyse_only or model not in args.models,
            args.retry_failed,
            f"δ-SPH {model}",
        )
        if status == "finished":
            rows += [window_row(out, model, *w) for w in WINDOWS]
            continue
        kept = [r for r in old if r.get("boundary_force", "pressure_and_contact") == model]
        print(f"δ-SPH dam break L/40, {model}: {status}; {len(kept)} rows kept from {CSV.name}")
        rows += [{"boundary_force": model, **r} for r in kept]
    write_csv(
        rows,
        CSV,
        list(dict.fromkeys(k for r in rows for k in r)),
        comment="δ-SPH dam break L/40 momentum budget per window and wall force model, "
        "impulses N s/m (validation/delta_sph_momentum_budget.py)",
    )
    for r in rows:
        print(
            f"{r['boundary_force']:21s} {r['window']:9s} residual_external x "
            f"{100 * float(r['residual_external_rel_x']):9.2e} % y "
            f"{100 * float(r['residual_external_rel_y']):9.2e} %   closure x "
            f"{float(r['closure_rel_x']):.1e} y {float(r['closure_rel_y']):.1e}"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
