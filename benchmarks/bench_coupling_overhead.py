"""Coupling overhead of a real coupled run at about 20k particles, per transport.

scenarios/hydrostatic_plate_2d.toml at l0 = 0.01 m (20 000 fluid particles, about 23 000 in all),
implicit IQN-ILS, run with ``mpsfem run`` over inproc, mpi (``mpirun -n 2``) and zenoh (the fluid
starts the structure). From the per-window wall times in ``/coupling/wall_*`` (windows after the
first ``--skip``):

* fluid: the MPS sub-steps, including the fluid side's coupling work (placing the structure
  particles, the thin-member neighbour filter, the forces; reported separately from the root
  attribute ``fluid_coupling_times``);
* structure: the structure's steps plus, for mpi / zenoh, the transport (remote calls); the
  transport share is this minus the inproc structure time;
* mapping, acceleration.

overhead = (mapping + acceleration + transport) / window time, and with the fluid-side coupling
work added ("overhead incl. fluid side"). Writes benchmarks/results/coupling_overhead.csv.

``--sweep [--case plate|obstacle]``: the added-mass stress test instead. The plate's density is set so that the mass
ratio (rho_s h) / (rho_w H) runs from 10 down to 0.01 (self-weight off: the static deflection is
the water's, 6.43e-5 m), at l0 = 0.05 m for 0.03 s (150 windows); each ratio runs explicit,
implicit Aitken and implicit IQN-ILS coupling. Divergence is the code's own verdict (the
explicit scheme's added-mass detector, CouplingDivergedError; a window not converged in
max_iterations stops a run only with on_divergence = "stop"; the scenario continues and records
it: column windows_not_converged). Writes benchmarks/results/coupling_added_mass.csv
(iterations per window: mean and max).

``--case obstacle``: the same sweep on scenarios/dam_break_elastic_obstacle_2d.toml (l0 = L/40),
mass ratio with the obstacle's thickness h = 0.012 m and the column height H = 0.292 m (the
scenario's own ratio is 0.103), to 0.3 s (the surge hits the plate at about 0.15 s; the first
tip peak follows); column displacement_m is the peak tip displacement. Writes
benchmarks/results/coupling_added_mass_obstacle.csv.

    .venv/bin/python benchmarks/bench_coupling_overhead.py [--windows 25] [--threads 1]
    .venv/bin/python benchmarks/bench_coupling_overhead.py --sweep [--case obstacle]
"""

from __future__ import annotations

import argparse
import ast
import csv
import os
import shutil
import socket
import subprocess
import sys
import tempfile
from pathlib import Path

import h5py
import numpy as np

ROOT = Path(__file__).resolve().parents[1]
SCENE = ROOT / "scenarios" / "hydrostatic_plate_2d.toml"
BIN = Path(sys.executable).parent
MPIRUN = str(BIN / "mpirun") if (BIN / "mpirun").exists() else shutil.which("mpirun")
WINDOW = 2e-4


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def launch(transport: str, out: Path, windows: int, threads: int, spacing: float) -> None:
    sets = [
        f"fluid.spacing={spacing}",
        f"run.threads={threads}",
        "output.snapshot_interval=0",
        "output.checkpoint_interval=0",
        "output.probe_interval=0.001",
    ]
    if transport == "zenoh":
        sets.append(
            f'coupling.transport={{kind = "zenoh", endpoint = "tcp/127.0.0.1:{free_port()}"}}'
        )
    args = ["-m", "mpsfem.cli", "run", str(SCENE), "--no-progress", "--out", str(out)]
    args += ["--end-time", repr(windows * WINDOW)]
    for s in sets:
        args += ["--set", s]
    if transport == "mpi":
        cmd = [MPIRUN, "-n", "2", sys.executable, *args, "--transport", "mpi"]
    else:
        cmd = [sys.executable, *args]
    env = dict(os.environ, NUMBA_NUM_THREADS=str(threads), OPENBLAS_NUM_THREADS="1")
    p = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=3600)
    if p.returncode != 0:
        raise RuntimeError(f"{transport}: {p.stderr[-2000:]}")


def measure(path: Path, skip: int) -> dict[str, float]:
    with h5py.File(path, "r") as h5:
        c = h5["coupling"]
        cols = {k: c[f"wall_{k}"][skip:] for k in ("fluid", "structure", "mapping", "acceleration")}
        it = c["iterations"][skip:]
        n_win = int(h5.attrs["windows"])
        fluid_side = ast.literal_eval(h5.attrs["fluid_coupling_times"])
        n_part = int(h5.attrs["particles"])
    out = {k: float(np.mean(v)) for k, v in cols.items()}
    out["iterations"] = float(np.mean(it))
    # the fluid-side coupling work is only known for the whole run: per window on average
    out["fluid_side"] = sum(fluid_side.values()) / n_win
    out["filter"] = fluid_side["filter"] / n_win
    out["n_particles"] = n_part
    return out


RATIOS = (10.0, 3.0, 1.0, 0.3, 0.1, 0.03, 0.01)
SCHEMES = (("explicit", None), ("implicit", "aitken"), ("implicit", "iqn-ils"))
#: ``--schemes`` names: the acceleration, or "explicit"
SCHEME_NAMES = {accel or scheme: (scheme, accel) for scheme, accel in SCHEMES}


# the two stress-test cases: scenario, (water depth H, structural thickness h) of the mass ratio
# (rho_s h) / (rho_w H), the displacement probe and its component
CASES = {
    "plate": (SCENE, 2.0, 0.05, "mid_deflection", 1),
    "obstacle": (ROOT / "scenarios" / "dam_break_elastic_obstacle_2d.toml", 0.292, 0.012, "tip", 0),
}


def sweep(
    case: str,
    out: Path,
    spacing: float | None,
    end_time: float,
    threads: int,
    ratios: tuple[float, ...] = RATIOS,
    schemes: tuple[tuple[str, str | None], ...] = SCHEMES,
    extra: tuple[str, ...] = (),
) -> None:
    """The added-mass stress test on the hydrostatic plate or the elastic obstacle (see the
    module docstring); ``extra``: more ``--set`` overrides for every run."""
    from mpsfem.scenario.loader import load_scenario
    from mpsfem.simulation import RunFailed, run_coupled

    scene, H, h, probe, comp = CASES[case]
    rho_w = 1000.0
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for ratio in ratios:
            rho_s = ratio * rho_w * H / h
            for scheme, accel in schemes:
                sets = [
                    f"run.threads={threads}",
                    f"structure.members.0.material.density={rho_s!r}",
                    "structure.members.0.self_weight=false",
                    "output.snapshot_interval=0",
                    "output.checkpoint_interval=0",
                    "output.probe_interval=0",
                    f'coupling.scheme="{scheme}"',
                ]
                if spacing is not None:
                    sets.append(f"fluid.spacing={spacing}")
                sets += list(extra)
                if accel:
                    sets.append(f'coupling.acceleration={{kind = "{accel}"}}')
                loaded = load_scenario(scene, sets)
                path = Path(tmp) / f"r{ratio}_{scheme}_{accel}.h5"
                verdict = "stable"
                try:
                    run_coupled(loaded, path, end_time, progress=False, log=lambda m: None)
                except RunFailed as exc:
                    cause = exc.__cause__
                    verdict = f"{type(cause).__name__}: {str(cause).split(':')[0]}"
                with h5py.File(path, "r") as h5:
                    it = h5["coupling/iterations"][:] if "coupling" in h5 else np.zeros(0)
                    conv = h5["coupling/converged"][:] if "coupling" in h5 else np.zeros(0)
                    w = h5[f"probes/{probe}/value"][:, comp]
                    tw = h5[f"probes/{probe}/time"][:]
                    wall = float(h5.attrs.get("wall_time", np.nan))
                row = {
                    "case": case,
                    "mass_ratio": ratio,
                    "rho_s": rho_s,
                    "scheme": scheme,
                    "acceleration": accel or "",
                    "verdict": verdict,
                    "windows": int(it.size),
                    "iterations_mean": round(float(it.mean()), 3) if it.size else "",
                    "iterations_max": int(it.max()) if it.size else "",
                    "windows_not_converged": int((conv == 0).sum()),
                    # plate: the settled deflection; obstacle: the peak tip displacement
                    "displacement_m": (
                        float(w[tw >= 0.5 * end_time].mean())
                        if case == "plate"
                        else float(w[np.argmax(np.abs(w))])
                    )
                    if verdict == "stable"
                    else "",
                    "wall_s": round(wall, 1),
                }
                rows.append(row)
                print(row, flush=True)
    out.parent.mkdir(parents=True, exist_ok=True)
    with open(out, "w", newline="") as f:
        wr = csv.DictWriter(f, fieldnames=list(rows[0]))
        wr.writeheader()
        wr.writerows(rows)
    print(f"wrote {out}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sweep", action="store_true", help="added-mass stress test instead")
    ap.add_argument(
        "--end-time", type=float, default=None, help="sweep: simulated time, s (0.03 / 0.3)"
    )
    ap.add_argument("--case", choices=sorted(CASES), default="plate", help="sweep: which case")
    ap.add_argument("--windows", type=int, default=25)
    ap.add_argument("--skip", type=int, default=5, help="warm-up windows left out")
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--spacing", type=float, default=0.01)
    ap.add_argument(
        "--out",
        type=Path,
        default=None,
        help="CSV (default: benchmarks/results/coupling_overhead.csv, or the sweep's file)",
    )
    ap.add_argument(
        "--ratios", default=None, help="sweep: comma-separated mass ratios (default: all seven)"
    )
    ap.add_argument(
        "--schemes",
        default=None,
        help="sweep: comma-separated explicit, aitken, iqn-ils (default: all three)",
    )
    ap.add_argument(
        "--set", dest="sets", action="append", default=[], help="sweep: extra KEY=VALUE override"
    )
    args = ap.parse_args()
    if args.sweep:
        if args.case == "plate":
            spacing = args.spacing if args.spacing != 0.01 else 0.05
            name = "coupling_added_mass.csv"
        else:  # the obstacle keeps its scenario's l0 = L/40 unless --spacing is given
            spacing = args.spacing if args.spacing != 0.01 else None
            name = "coupling_added_mass_obstacle.csv"
        end = (
            args.end_time if args.end_time is not None else (0.03 if args.case == "plate" else 0.3)
        )
        ratios = tuple(float(r) for r in args.ratios.split(",")) if args.ratios else RATIOS
        names = args.schemes.split(",") if args.schemes else list(SCHEME_NAMES)
        unknown = [k for k in names if k not in SCHEME_NAMES]
        if unknown:
            ap.error(f"--schemes {args.schemes!r}: {unknown} not in {', '.join(SCHEME_NAMES)}")
        schemes = tuple(SCHEME_NAMES[k] for k in names)
        out = args.out or ROOT / "benchmarks/results" / name
        sweep(args.case, out, spacing, end, args.threads, ratios, schemes, tuple(args.sets))
        return
    transports = ["inproc"] + (["mpi"] if MPIRUN else []) + ["zenoh"]
    rows = {}
    with tempfile.TemporaryDirectory() as tmp:
        for tr in transports:
            path = Path(tmp) / f"{tr}.h5"
            launch(tr, path, args.windows, args.threads, args.spacing)
            rows[tr] = measure(path, args.skip)
    base = rows["inproc"]["structure"]
    table = []
    for tr, r in rows.items():
        total = r["fluid"] + r["structure"] + r["mapping"] + r["acceleration"]
        transport = max(r["structure"] - base, 0.0)
        coupling = r["mapping"] + r["acceleration"] + transport
        table.append(
            {
                "transport": tr,
                "spacing_m": args.spacing,
                "particles": r["n_particles"],
                "threads": args.threads,
                "windows": args.windows - args.skip,
                "iterations_per_window": round(r["iterations"], 3),
                "window_ms": round(1e3 * total, 3),
                "fluid_ms": round(1e3 * r["fluid"], 3),
                "structure_ms": round(1e3 * min(r["structure"], base), 3),
                "transport_ms": round(1e3 * transport, 3),
                "mapping_ms": round(1e3 * r["mapping"], 3),
                "acceleration_ms": round(1e3 * r["acceleration"], 3),
                "fluid_side_ms": round(1e3 * r["fluid_side"], 3),
                "filter_ms": round(1e3 * r["filter"], 3),
                "overhead_pct": round(100 * coupling / total, 2),
                "overhead_incl_fluid_side_pct": round(
                    100 * (coupling + r["fluid_side"]) / total, 2
                ),
            }
        )
    out = args.out or ROOT / "benchmarks/results/coupling_overhead.csv"
    out.parent.mkdir(parents=True, exist_ok=True)
    with open(out, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(table[0]))
        w.writeheader()
        w.writerows(table)
    for row in table:
        print(row)
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
