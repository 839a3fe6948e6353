"""The piston under a water column: is the added-mass force in phase and of full size?
(issue "Interface loads", item 4)

scenarios/piston_column_2d.toml: a column 1 m wide and H = 2 m deep on a floor that oscillates
vertically, s(t) = A sin(w t), A = 1e-5 m. Incompressible, the whole column moves with the floor,
so the floor carries F_y = -rho H L (g + a) = -rho H L g + rho H L A w^2 sin(w t): the oscillating
part has amplitude rho H L A w^2 and no phase shift. Each case fits F_y = c0 + c1 sin(w t) +
c2 cos(w t) over its last two periods (the force probe samples every step, ``average = false``)
and reports the amplitude ratio to rho H L A w^2 and the phase (negative: the force lags).

Cases (0.15 s each): 20 Hz and 75 Hz (the 2 m column's wet plate mode in docs/validation.md) at
dt = 2e-4 s (the scenario's) and 1e-4 s, with the default numerics and with the walls'
acceleration in the ghosts (``fluid.pressure.wall_acceleration``), and at 75 Hz / 2e-4 s with
the pressure integral alone, the higher-order source (HS), the higher-order Laplacian (HL),
gamma = 0 and l0 halved: what moves the lag?

Writes validation/results/piston_added_mass.csv and prints the table.

    python validation/piston_added_mass.py [--threads 1] [--analyse-only] [--retry-failed]
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
from results_csv import write_csv  # noqa: E402

ROOT = case_runner.ROOT
SCENARIO = ROOT / "scenarios" / "piston_column_2d.toml"
RESULTS_DIR = ROOT / "validation" / "results"
RHO, G, H, WIDTH = 1000.0, 9.81, 2.0, 1.0
#: (label, frequency Hz, dt s, extra overrides)
WALL_ACCELERATION = ["fluid.pressure.wall_acceleration=true"]
CASES = [
    ("default", 20.0, 2e-4, []),
    ("default", 75.0, 2e-4, []),
    ("default", 20.0, 1e-4, []),
    ("default", 75.0, 1e-4, []),
    ("wall_acceleration", 20.0, 2e-4, WALL_ACCELERATION),
    ("wall_acceleration", 75.0, 2e-4, WALL_ACCELERATION),
    ("wall_acceleration", 20.0, 1e-4, WALL_ACCELERATION),
    ("wall_acceleration", 75.0, 1e-4, WALL_ACCELERATION),
    ("pressure_integral", 75.0, 2e-4, ["fluid.boundary_force=pressure_integral"]),
    ("HS", 75.0, 2e-4, ["fluid.pressure.source_term=higher_order"]),
    ("HL", 75.0, 2e-4, ["fluid.pressure.laplacian=higher_order"]),
    ("gamma=0", 75.0, 2e-4, ["fluid.pressure.gamma=0"]),
    ("l0=0.01", 75.0, 2e-4, ["fluid.spacing=0.01"]),
]


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
    """Amplitude ratio and phase (deg) of the floor force's oscillating part, last 2 periods."""
    with h5py.File(path, "r") as h5:
        t = h5["probes/floor_force/time"][:]
        f = h5["probes/floor_force/value"][:, 1]
        motion = json.loads(h5.attrs["scenario_resolved"])["fluid"]["walls"][2]["motion"]
        wall = float(h5.attrs.get("wall_time", np.nan))
    amp, period = motion["amplitude"], motion["period"]
    w = 2.0 * np.pi / period
    sel = t > t[-1] - 2.0 * period
    basis = np.c_[np.ones(sel.sum()), np.sin(w * t[sel]), np.cos(w * t[sel])]
    c = np.linalg.lstsq(basis, f[sel], rcond=None)[0]
    mass = RHO * H * WIDTH
    exact = mass * amp * w * w
    return {
        "mean_force": float(c[0]),
        "mean_exact": -mass * G,
        "amplitude": float(np.hypot(c[1], c[2])),
        "amplitude_exact": exact,
        "amplitude_ratio": float(np.hypot(c[1], c[2]) / exact),
        "phase_deg": float(np.degrees(np.arctan2(c[2], c[1]))),
        "wall_time_s": wall,
    }


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    case_runner.add_run_options(ap)
    args = ap.parse_args(argv)
    RESULTS_DIR.mkdir(parents=True, exist_ok=True)
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
    print("variant            f (Hz)  dt (s)   amplitude / exact   phase (deg)   mean / exact")
    for r in rows:
        print(
            f"{r['variant']:18s} {r['frequency_hz']:6g}  {r['dt_s']:6g}   {r['amplitude_ratio']:8.3f}"
            f"          {r['phase_deg']:+6.1f}        {r['mean_force'] / r['mean_exact']:.4f}"
        )
    return 0 if len(paths) == len(CASES) else 1


if __name__ == "__main__":
    sys.exit(main())
