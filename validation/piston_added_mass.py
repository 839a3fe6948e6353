"""The piston under a water column: is the added-mass force in phase and of full size?
(issue "Interface loads", item 4)

scenarios/piston_column_2d.toml: a column 1 m wide and H = 2 m deep on a floor that oscillates
vertically, s(t) = A sin(w t), A = 1e-5 m. Incompressible, the whole column moves with the floor,
so the floor carries F_y = -rho H L (g + a) = -rho H L g + rho H L A w^2 sin(w t): the oscillating
part has amplitude rho H L A w^2 and no phase shift. Each case fits F_y = c0 + c1 sin(w t) +
c2 cos(w t) over its last two periods (the force probe samples every step, ``average = false``)
and reports the amplitude ratio to rho H L A w^2, the phase (negative: the force lags) and the
complex error |F / F_exact - 1|, as sampled at the step's end and against the exact force's
mean over each step (``*_step_mean``: a projection step's pressure is that mean; against the
instant t + dt it lags by w dt / 2, 2.7 deg at 75 Hz and dt = 2e-4 s).

Cases (0.15 s each): 20 Hz and 75 Hz (the 2 m column's wet plate mode in docs/validation.md) at
dt = 2e-4 s (the scenario's) and 1e-4 s, with the default numerics and with the walls'
acceleration in the ghosts (``fluid.pressure.wall_acceleration``), with it and the buried
wall particles as ghosts (``fluid.pressure.buried_walls = "ghost"``: the side walls' layers
below the floor, p = 0 neighbours of the corner fluid otherwise), the latter alone at 75 Hz /
2e-4 s, and at 75 Hz / 2e-4 s with
the pressure integral alone, the higher-order source (HS), the higher-order Laplacian (HL),
gamma = 0 and l0 halved: what moves the lag?

Also at 75 Hz: the stabilised conservative gradient (``tanaka`` under its time-step limit,
loads by momentum exchange; docs/fluid.md), with the walls' acceleration and with particle
shifting (``fluid.pressure.shifting = 0.1``), and the default numerics with shifting.

Writes validation/results/piston_added_mass.csv and prints the table.

``--defaults`` runs instead the cross-case check of ``wall_acceleration``: the hydrostatic
plate (scenarios/hydrostatic_plate_2d.toml, l0 = 0.02 m, 0.25 s; mean deflection over
0.05-0.25 s against 6.85e-5 m) and the elastic obstacle at L/20 (0.25 s; peak tip, force
ringing), each with the default numerics, the walls' acceleration, it with buried ghosts and
buried ghosts alone (``--variants`` / ``--cases`` pick some; the CSV keeps the other rows);
writes validation/results/wall_acceleration_cases.csv.

    python validation/piston_added_mass.py [--threads 1] [--analyse-only] [--retry-failed]
                                           [--defaults [--variants V ...] [--cases C ...]]
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import h5py
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import case_runner  # noqa: E402 - validation/case_runner.py: resumable runs of one case
from results_csv import read_csv, write_csv  # noqa: E402

ROOT = case_runner.ROOT
SCENARIO = ROOT / "scenarios" / "piston_column_2d.toml"
RESULTS_DIR = ROOT / "validation" / "results"
RHO, G, H, WIDTH = 1000.0, 9.81, 2.0, 1.0
#: (label, frequency Hz, dt s, extra overrides)
WALL_ACCELERATION = ["fluid.pressure.wall_acceleration=true"]
#: buried boundary particles (the side walls' layers below the floor) as ghosts, not p = 0
BURIED_GHOST = ["fluid.pressure.buried_walls=ghost"]
#: the stabilised conservative gradient (docs/fluid.md, "Momentum budget")
LIMITED = [
    "fluid.pressure.gradient=tanaka",
    "fluid.pressure.pressure_courant=0.25",
    "fluid.boundary_force=momentum_exchange",
]
CASES = [
    ("default", 20.0, 2e-4, []),
    ("default", 75.0, 2e-4, []),
    ("default", 20.0, 1e-4, []),
    ("default", 75.0, 1e-4, []),
    ("wall_acceleration", 20.0, 2e-4, WALL_ACCELERATION),
    ("wall_acceleration", 75.0, 2e-4, WALL_ACCELERATION),
    ("wall_acceleration", 20.0, 1e-4, WALL_ACCELERATION),
    ("wall_acceleration", 75.0, 1e-4, WALL_ACCELERATION),
    ("wall_acceleration+buried_ghost", 20.0, 2e-4, [*WALL_ACCELERATION, *BURIED_GHOST]),
    ("wall_acceleration+buried_ghost", 75.0, 2e-4, [*WALL_ACCELERATION, *BURIED_GHOST]),
    ("wall_acceleration+buried_ghost", 20.0, 1e-4, [*WALL_ACCELERATION, *BURIED_GHOST]),
    ("wall_acceleration+buried_ghost", 75.0, 1e-4, [*WALL_ACCELERATION, *BURIED_GHOST]),
    ("buried_ghost", 75.0, 2e-4, BURIED_GHOST),
    ("pressure_integral", 75.0, 2e-4, ["fluid.boundary_force=pressure_integral"]),
    ("HS", 75.0, 2e-4, ["fluid.pressure.source_term=higher_order"]),
    ("HL", 75.0, 2e-4, ["fluid.pressure.laplacian=higher_order"]),
    ("gamma=0", 75.0, 2e-4, ["fluid.pressure.gamma=0"]),
    ("l0=0.01", 75.0, 2e-4, ["fluid.spacing=0.01"]),
    ("tanaka_limited", 75.0, 2e-4, LIMITED),
    ("tanaka_limited+wall_acceleration", 75.0, 2e-4, [*LIMITED, *WALL_ACCELERATION]),
    ("tanaka_limited+shifting", 75.0, 2e-4, [*LIMITED, "fluid.pressure.shifting=0.1"]),
    ("shifting", 75.0, 2e-4, ["fluid.pressure.shifting=0.1"]),
]
#: the cross-case check of ``--defaults``: (case, scenario, overrides); each runs with and
#: without the walls' acceleration
PLATE = ROOT / "scenarios" / "hydrostatic_plate_2d.toml"
OBSTACLE = ROOT / "scenarios" / "dam_break_elastic_obstacle_2d.toml"
DEFAULTS_CASES = [
    ("hydrostatic_plate_0.02", PLATE, ["fluid.spacing=0.02", "run.end_time=0.25"]),
    ("obstacle_L20", OBSTACLE, ["fluid.spacing=0.0073", "run.end_time=0.25"]),
]
#: the variants of ``--defaults`` (``--variants`` picks some; the CSV keeps the others' rows)
DEFAULTS_VARIANTS = [
    ("default", []),
    ("wall_acceleration", WALL_ACCELERATION),
    ("wall_acceleration+buried_ghost", [*WALL_ACCELERATION, *BURIED_GHOST]),
    ("buried_ghost", BURIED_GHOST),
]
W_REF = 6.85e-5  # m, the 2D plate's static deflection (references.md section 5)


def case_path(label: str, freq: float, dt: float) -> Path:
    safe = label.replace("=", "").replace(".", "p")
    return RESULTS_DIR / f"piston_{safe}_{freq:g}Hz_dt{dt:g}.h5"


#: s: three periods at 20 Hz, the last two fitted after the start-up transient; longer runs at
#: dt = 1e-4 s grow a pressure instability after about 1750 steps (0.175 s), which the fit
#: of the last two periods would take for the response
END_TIME = 0.15


def overrides(freq: float, dt: float, extra: list[str]) -> list[str]:
    return [
        f"run.end_time={END_TIME:g}",
        f"fluid.walls.2.motion.period={1.0 / freq:.10g}",
        f"fluid.time_step.dt_max={dt:g}",
        f"fluid.time_step.dt_initial={dt:g}",
        *extra,
    ]


def fit(path: Path) -> dict:
    """Amplitude ratio and phase (deg) of the floor force's oscillating part, last 2 periods,
    and the complex error |F / F_exact - 1|: as sampled (each sample against the exact force at
    its time stamp, the step's end t + dt) and against the exact force's mean over the step
    (``_step_mean``: the same fit with the samples at t + dt / 2). The pressure of a projection
    step is the step's mean force: the walls' acceleration over the step (v(t + dt) - v(t)) /
    dt is the exact mean of a(t) over it, and against the instant t + dt it lags by w dt / 2."""
    with h5py.File(path, "r") as h5:
        t = h5["probes/floor_force/time"][:]
        f = h5["probes/floor_force/value"][:, 1]
        motion = json.loads(h5.attrs["scenario_resolved"])["fluid"]["walls"][2]["motion"]
        wall = float(h5.attrs.get("wall_time", np.nan))
    amp, period = motion["amplitude"], motion["period"]
    w = 2.0 * np.pi / period
    sel = t > t[-1] - 2.0 * period
    dt = float(np.median(np.diff(t[sel])))  # the run's fixed step (every step is sampled)
    mass = RHO * H * WIDTH
    exact = mass * amp * w * w  # rho H L A w^2: the added-mass force, in phase with -a
    out = {}
    for suffix, shift in (("", 0.0), ("_step_mean", 0.5 * dt)):
        ts = t[sel] - shift
        basis = np.c_[np.ones(sel.sum()), np.sin(w * ts), np.cos(w * ts)]
        c = np.linalg.lstsq(basis, f[sel], rcond=None)[0]
        z = complex(c[1], c[2]) / exact  # 1: the exact force rho H L A w^2 sin(w t)
        if not suffix:
            out |= {
                "mean_force": float(c[0]),
                "mean_exact": -mass * G,
                "amplitude": float(np.hypot(c[1], c[2])),
                "amplitude_exact": exact,
                "amplitude_ratio": abs(z),
            }
        out[f"phase{suffix}_deg"] = float(np.degrees(np.angle(z)))
        out[f"complex_error{suffix}"] = abs(z - 1.0)
    return out | {"wall_time_s": wall}


def defaults_row(case: str, variant: str, path: Path) -> dict:
    """The plate's mean mid-point deflection over 0.05-0.25 s against W_REF, or the obstacle's
    peak tip displacement and its force probe's ringing over the impact (0.12-0.25 s: RMS of
    the 1 ms sample-to-sample jump over the peak, as validation/momentum_budget.py)."""
    with h5py.File(path, "r") as h5:
        row = {"case": case, "variant": variant, "status": str(h5.attrs["status"])}
        row["wall_time_s"] = float(h5.attrs.get("wall_time", np.nan))
        if case.startswith("hydrostatic_plate"):
            t = h5["probes/mid_deflection/time"][:]
            v = h5["probes/mid_deflection/value"][:, -1]
            mean = -float(v[t >= 0.05].mean())
            return row | {"deflection_mean_m": mean, "deflection_error_rel": mean / W_REF - 1}
        t = h5["probes/tip/time"][:]
        tip = h5["probes/tip/value"][:, 0]
        tf = h5["probes/obstacle_force/time"][:]
        f = h5["probes/obstacle_force/value"][:, 0]
    sel = (tf >= 0.12) & (tf <= 0.25)
    peak = float(np.abs(f[sel]).max())
    ring = float(np.sqrt(np.mean(np.diff(f[sel]) ** 2)) / peak)
    return row | {
        "tip_peak_mm": float(1e3 * tip.max()),
        "tip_peak_time_s": float(t[np.argmax(tip)]),
        "force_peak": peak,
        "ringing": ring,
    }


def run_defaults(args) -> int:
    """``--defaults``: does the walls' acceleration change the coupled cases? (The dam break's
    walls are static: bit-identical either way.)"""
    csv_path = RESULTS_DIR / "wall_acceleration_cases.csv"
    kept = {}  # rows of earlier runs whose results files are not here (their variant not run)
    if csv_path.exists():
        kept = {(r["case"], r["variant"]): r for r in read_csv(csv_path)}
    rows = []
    for case, scene, sets in DEFAULTS_CASES:
        for variant, extra in DEFAULTS_VARIANTS:
            out = RESULTS_DIR / f"wall_acceleration_{case}_{variant}.h5"
            if (args.variants and variant not in args.variants) or (
                args.cases and case not in args.cases
            ):
                if (case, variant) in kept:
                    rows.append(kept[(case, variant)])
                continue
            status = case_runner.case_status(
                scene, out, [*sets, "output.snapshot_interval=0", *extra], args.threads,
                args.analyse_only, args.retry_failed, tag=f"[{case} {variant}]",
            )  # fmt: skip
            if status is not None:
                rows.append(defaults_row(case, variant, out))
    if not rows:
        print("nothing to analyse")
        return 1
    write_csv(
        rows,
        csv_path,
        list(dict.fromkeys(k for r in rows for k in r)),
        comment="fluid.pressure.wall_acceleration on coupled cases "
        "(validation/piston_added_mass.py --defaults)",
    )
    for r in rows:
        print({k: (round(v, 6) if isinstance(v, float) else v) for k, v in r.items()})
    return 0


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    case_runner.add_run_options(ap)
    ap.add_argument("--defaults", action="store_true", help="the cross-case check instead")
    ap.add_argument(
        "--variants",
        nargs="+",
        choices=[v for v, _ in DEFAULTS_VARIANTS],
        help="--defaults: run only these variants (default: all)",
    )
    ap.add_argument(
        "--cases",
        nargs="+",
        choices=[c for c, _, _ in DEFAULTS_CASES],
        help="--defaults: run only these cases (default: all)",
    )
    args = ap.parse_args(argv)
    RESULTS_DIR.mkdir(parents=True, exist_ok=True)
    if args.defaults:
        return run_defaults(args)
    cases = {
        (label, f, dt): (case_path(label, f, dt), overrides(f, dt, extra), f"[{label} {f:g} Hz]")
        for label, f, dt, extra in CASES
    }
    paths = case_runner.finished_cases(
        SCENARIO, cases, args.threads, args.analyse_only, args.retry_failed
    )
    rows = [
        {"variant": label, "frequency_hz": f, "dt_s": dt} | fit(path)
        for (label, f, dt), path in paths.items()
    ]
    if not rows:
        print("nothing to analyse")
        return 1
    write_csv(
        rows,
        RESULTS_DIR / "piston_added_mass.csv",
        comment="piston under a 2 m water column (validation/piston_added_mass.py); forces N/m",
    )
    print(
        "variant                           f (Hz)  dt (s)  amplitude / exact  phase (deg)  "
        "|F/F_ex - 1|  step mean: phase, |F/F_ex - 1|  mean / exact"
    )
    for r in rows:
        print(
            f"{r['variant']:32s} {r['frequency_hz']:6g}  {r['dt_s']:6g}  {r['amplitude_ratio']:8.3f}"
            f"           {r['phase_deg']:+6.2f}      {r['complex_error']:.4f}"
            f"        {r['phase_step_mean_deg']:+6.2f}, {r['complex_error_step_mean']:.4f}"
            f"          {r['mean_force'] / r['mean_exact']:.4f}"
        )
    return 0 if len(paths) == len(CASES) else 1


if __name__ == "__main__":
    sys.exit(main())
