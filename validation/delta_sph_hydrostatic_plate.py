"""Hydrostatic water column on a clamped elastic plate, coupled, δ-SPH beside MPS (issue 23).

scenarios/hydrostatic_plate_2d.toml (references.md section 5: Fourey et al. 2017, Khayyer et
al. 2018): water H = 2 m deep and 1 m wide on an aluminium plate strip L = 1 m, h = 0.05 m,
clamped at both ends, through the same coupler (implicit, IQN-ILS, shape-function mapping,
window 0.2 ms) with fluid.method = "delta-sph" (δ-SPHC, Wendland C2 h = 1.3 l0, RK4, the plate's
particles as moving dummy walls) and with "mps" (the scenario's defaults). The plate starts at
rest, takes the water load at once and oscillates about its static deflection; the script
reports the time mean of the mid deflection and of the plate force for t >= --settle (default
0.05 s) against beam theory, w_mid = (rho_w g H + rho_s g h) L^4 / (384 D) = 6.86e-5 m
(literature 6.85e-5 m), and rho g H L = 19 620 N/m, with the coupling iterations and the wall
time. Method "delta-sph-pairs" is δ-SPH with fluid.sph.structure_load = "normal_pairs" (the
fluid's pairs with the plate projected on its normals too); "delta-sph-wetted" is δ-SPH with
fluid.sph.wall_pressure = "wetted" (dry walls carry no pressure). Writes
validation/results/delta_sph_hydrostatic_plate.csv (after each case); rows of (method, spacing)
pairs not run are kept from it.

    NUMBA_NUM_THREADS=1 python validation/delta_sph_hydrostatic_plate.py \\
        [--spacings 0.05 0.02] [--methods delta-sph mps delta-sph-pairs] [--end-time 0.2]
        [--settle 0.05]
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import h5py

sys.path.insert(0, str(Path(__file__).resolve().parent))
from results_csv import read_csv, write_csv  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
SCENE = ROOT / "scenarios" / "hydrostatic_plate_2d.toml"
CSV = ROOT / "validation" / "results" / "delta_sph_hydrostatic_plate.csv"
RHO, G, H, L = 1000.0, 9.81, 2.0, 1.0
D = 67.5e9 * 0.05**3 / (12 * (1 - 0.34**2))  # plate-strip rigidity E h^3 / (12 (1 - nu^2)), N m
W_STATIC = (RHO * G * H + 2700.0 * G * 0.05) * L**4 / (384 * D)  # clamped-clamped beam, m
#: method name -> (fluid.method, extra --set overrides)
METHODS = {
    "delta-sph": ("delta-sph", []),
    "mps": ("mps", []),
    "delta-sph-pairs": ("delta-sph", ['fluid.sph.structure_load="normal_pairs"']),
    "delta-sph-wetted": ("delta-sph", ['fluid.sph.wall_pressure="wetted"']),
}


def run(method: str, dx: float, t_end: float, settle: float, folder: Path) -> dict:
    from mpsfem.scenario.loader import load_scenario
    from mpsfem.simulation import run_coupled

    fluid_method, extra = METHODS[method]
    loaded = load_scenario(
        SCENE,
        [
            f'fluid.method="{fluid_method}"',
            f"fluid.spacing={dx}",
            "run.threads=1",
            "output.snapshot_interval=0",
            f"output.checkpoint_interval={t_end}",
            *extra,
        ],
    )
    out = folder / f"{method}_{dx}.h5"
    summary = run_coupled(loaded, out, t_end, progress=False, log=lambda m: None)
    with h5py.File(out, "r") as h5:
        tw = h5["probes/mid_deflection/time"][()]
        w = h5["probes/mid_deflection/value"][()][:, 1]
        tf = h5["probes/plate_force/time"][()]
        f = h5["probes/plate_force/value"][()]
        it = h5["coupling/iterations"][()]
        conv = h5["coupling/converged"][()]
        n = int(h5.attrs["particles"])
    sw, sf = tw >= settle - 1e-12, tf > settle + 1e-12  # force samples: interval means
    mean_w = float(w[sw].mean())
    mean_f = f[sf].mean(axis=0)
    return {
        "method": method,
        "spacing_m": dx,
        "particles": n,
        "t_end_s": t_end,
        "windows": int(it.size),
        "mean_w_mid_m": mean_w,
        "w_rel_error": -mean_w / W_STATIC - 1.0,
        "std_w_mid_m": float(w[sw].std()),
        "mean_force_y_N_per_m": float(mean_f[1]),
        "force_over_rho_g_H_L": float(-mean_f[1] / (RHO * G * H * L)),
        "mean_force_x_N_per_m": float(mean_f[0]),
        "iterations_mean": float(it.mean()),
        "iterations_max": int(it.max()),
        "not_converged": int((conv == 0).sum()),
        "wall_time_s": float(summary.wall_time),
    }


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--spacings", type=float, nargs="+", default=[0.05, 0.02], help="l0, m")
    ap.add_argument("--methods", nargs="+", choices=list(METHODS), default=["delta-sph", "mps"])
    ap.add_argument("--end-time", type=float, default=0.2, help="s (default 0.2)")
    ap.add_argument("--settle", type=float, default=0.05, help="mean from this time, s")
    args = ap.parse_args()
    print(f"beam theory w_mid = {W_STATIC:.4e} m, rho g H L = {RHO * G * H * L:.0f} N/m")
    done = {(m, dx) for m in args.methods for dx in args.spacings}
    old = read_csv(CSV) if CSV.is_file() else []
    rows = [r for r in old if (r["method"], float(r["spacing_m"])) not in done]  # kept
    with tempfile.TemporaryDirectory() as tmp:
        for dx in args.spacings:
            for method in args.methods:
                r = run(method, dx, args.end_time, args.settle, Path(tmp))
                rows.append(r)
                print(
                    f"{method:15} l0 {dx:<5} {r['particles']:6d} particles  mean w_mid "
                    f"{r['mean_w_mid_m']:.4e} m ({r['w_rel_error']:+.2%}, std "
                    f"{r['std_w_mid_m']:.1e})  F_y/(rho g H L) {r['force_over_rho_g_H_L']:.4f}  "
                    f"it. {r['iterations_mean']:.2f} ({r['iterations_max']})  not conv. "
                    f"{r['not_converged']}  wall {r['wall_time_s']:.0f} s",
                    flush=True,
                )
                write_csv(
                    rows,
                    CSV,
                    list(dict.fromkeys(k for r in rows for k in r)),
                    comment="hydrostatic plate, coupled, delta-sph vs mps: time means for t >= "
                    f"{args.settle} s (validation/delta_sph_hydrostatic_plate.py)",
                )
    print(f"wrote {CSV}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
