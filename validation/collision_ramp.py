"""A collision that fades in (``fluid.collision.ramp``): what it changes across the cases.

The collision model (fluid_mps/collision.py) hands a pair the whole impulse (1 + e) a m once it
is closer than ``distance`` and nothing beyond. A member's load holds the impulses its
particles receive (``fluid.boundary_force = "pressure_and_contact"``, the default), so it jumps
when one fluid particle crosses the threshold, whatever the displacement that moved it. Under
implicit coupling a window's fixed-point map then has no fixed point: on the elastic obstacle
at mass ratio 1e-2 (shaped fictitious mass, Aitken) the five windows that never converge swing
between two loads (-15 / -250 N/m) for tip changes of 1e-7 m (docs/coupler.md, "Contact that
fades in"). ``ramp`` lets the impulse fall linearly to zero over the last share of the
distance. This study measures what that does where no light member asks for it, with the
ramp 0.1 beside the default (0), back to back on the current code:

* the dam break's far-wall gauge at L/40, Courant 0.2 (``dam_break_wall_gauge.py``'s set-up
  and metric: noise = RMS about an 11 ms Savitzky-Golay fit, relative to the mean), and its
  front against Koshizuka & Oka, raw and after the best gate-lag offset (``dam_break.py``);
* the elastic obstacle (its own mass ratio 0.103) at L/20 and L/40 to 0.3 s: the tip's peak
  u_x and its time, the peak of the 1 ms force samples over the impact 0.12-0.25 s and their
  ringing (RMS sample-to-sample jump / peak, issue 20's metric; ``momentum_budget.ringing``),
  coupling iterations per window and windows not converged;
* the same obstacle made stiff (E = 2e11 Pa, a member that does not move) at L/20: the
  fluid's own load noise, of which the contact impulses are a part;
* the rubber gate (scenarios/elastic_gate_2d.toml, issue 21's co-rotational member) at
  l0 = 3 mm with the coupling's relative tolerance 1e-4 instead of 1e-3 (docs/validation.md
  found it diverging at 0.144 s there), to 0.4 s: tip peaks, iterations, unconverged windows,
  and where a run stops, when and why (a stopped run's row reads its results file up to the
  stop).

Every case is an ``mpsfem run`` subprocess, resumable (validation/case_runner.py). Writes
validation/results/collision_ramp.csv (rows of cases whose results file is not here are kept)
and prints the table.

    python validation/collision_ramp.py [--threads 1] [--analyse-only] [--retry-failed]
        [--ramps 0.1] [--cases gauge40 obstacle20 obstacle40 stiff20 gate3_rtol1e-4
        gate3_rtol1e-4_wc gate3_rtol1e-4_wc_cs]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import h5py
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import case_runner  # noqa: E402 - validation/case_runner.py: resumable runs of one case
import dam_break_wall_gauge as gauge  # noqa: E402
from dam_break import L, comparison, front_curve, references  # noqa: E402
from momentum_budget import ringing  # noqa: E402
from results_csv import print_rows, read_csv, write_csv  # noqa: E402

ROOT = case_runner.ROOT
RESULTS_DIR = ROOT / "validation" / "results"
CSV = RESULTS_DIR / "collision_ramp.csv"
OBSTACLE = ROOT / "scenarios" / "dam_break_elastic_obstacle_2d.toml"
STIFF = ["structure.members.0.material.youngs_modulus=2e11"]
GATE = ROOT / "scenarios" / "elastic_gate_2d.toml"
#: the rubber gate at 3 mm to 0.4 s with the coupling's relative tolerance 1e-4
GATE3_RTOL1E4 = [
    "fluid.spacing=0.003",
    "coupling.convergence.relative_tolerance=0.0001",
    "run.end_time=0.4",
    "output.snapshot_interval=0",
]
#: the same, weakly compressible
GATE3_WC = [*GATE3_RTOL1E4, "fluid.pressure.compressibility=3.6e-6", "fluid.pressure.shifting=0.1"]
#: case key -> (scenario, L / l0, overrides besides the ramp)
CASES = {
    "gauge40": (gauge.SCENARIO, 40, gauge.overrides(40, 0.2)),
    "obstacle20": (OBSTACLE, 20, [f"fluid.spacing={L / 20:.6g}", "run.end_time=0.3"]),
    "obstacle40": (OBSTACLE, 40, [f"fluid.spacing={L / 40:.6g}", "run.end_time=0.3"]),
    "stiff20": (OBSTACLE, 20, [f"fluid.spacing={L / 20:.6g}", "run.end_time=0.3", *STIFF]),
    "gate3_rtol1e-4": (GATE, 0, GATE3_RTOL1E4),
    # the same, weakly compressible (issue 21: c = 10 u_max = 16.6 m/s for the 0.14 m column,
    # with particle shifting; docs/validation.md, "Rubber gate")
    "gate3_rtol1e-4_wc": (GATE, 0, GATE3_WC),
    # and started in its compressed equilibrium (fluid.pressure.compressed_start; docs/fluid.md)
    "gate3_rtol1e-4_wc_cs": (GATE, 0, [*GATE3_WC, "fluid.pressure.compressed_start=true"]),
}
IMPACT = (0.12, 0.25)
COLUMNS = [
    "case",
    "resolution_L_over_l0",
    "ramp",
    "status",
    "t_end_s",
    "noise_relative",
    "mean_after_impact_pa",
    "peak_pa",
    "front_rms_error_ko",
    "front_offset_ms_ko",
    "front_error_after_offset_ko",
    "tip_peak_mm",
    "tip_peak_time_s",
    "tip_dy_peak_mm",
    "force_peak_n_m",
    "ringing",
    "iterations_mean",
    "iterations_max",
    "not_converged",
    "steps",
    "wall_time_s",
]


def results_path(case: str, ramp: float) -> Path:
    return RESULTS_DIR / f"collision_ramp_{case}_r{ramp:g}.h5"


def run_row(path: Path) -> dict:
    """The run's status, its last coupling window's end (s; NaN for a fluid-only run), its
    fluid steps and wall time (s)."""
    with h5py.File(path, "r") as h5:
        t = h5["coupling/time"][:] if "coupling/time" in h5 else np.full(1, np.nan)
        return {
            "status": str(h5.attrs.get("status", "unknown")),
            "t_end_s": float(t[-1]),
            "steps": int(h5.attrs.get("steps", -1)),
            "wall_time_s": float(h5.attrs.get("wall_time", np.nan)),
        }


def gauge_row(path: Path, refs: dict) -> dict:
    stats = gauge.gauge_statistics(*gauge.read_gauge(path))
    front = comparison(*front_curve(path), refs)
    return {
        "noise_relative": stats.noise_relative,
        "mean_after_impact_pa": stats.mean_after_impact_pa,
        "peak_pa": stats.peak_pa,
        "front_rms_error_ko": front["rms_error_ko"],
        "front_offset_ms_ko": front["offset_ms_ko"],
        "front_error_after_offset_ko": front["rms_error_shifted_ko"],
    }


def member_row(path: Path, force_probe: str | None = None) -> dict:
    """The member's tip (the ``tip`` probe: peak dx and its time, peak dy, mm), the coupling
    windows' iterations and unconverged count, and with ``force_probe`` its peak and ringing over
    :data:`IMPACT`."""
    with h5py.File(path, "r") as h5:
        t = h5["probes/tip/time"][:]
        tip = h5["probes/tip/value"][:]
        it = h5["coupling/iterations"][:]
        conv = h5["coupling/converged"][:]
    k = int(np.argmax(tip[:, 0]))
    row = {
        "tip_peak_mm": 1e3 * float(tip[k, 0]),
        "tip_peak_time_s": float(t[k]),
        "tip_dy_peak_mm": 1e3 * float(tip[:, 1].max()),
        "iterations_mean": float(it.mean()),
        "iterations_max": int(it.max()),
        "not_converged": int((conv == 0).sum()),
    }
    if force_probe is not None:
        row["force_peak_n_m"], row["ringing"] = ringing(path, force_probe, *IMPACT)
    return row


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    case_runner.add_run_options(ap)
    ap.add_argument("--ramps", type=float, nargs="+", default=[0.1], help="ramps beside 0")
    ap.add_argument("--cases", nargs="+", choices=list(CASES), default=list(CASES))
    args = ap.parse_args(argv)
    ramps = [0.0, *[r for r in args.ramps if r != 0.0]]
    refs = references()
    rows = {}
    if CSV.is_file():  # rows of cases not run or read here are kept
        for r in read_csv(CSV):
            rows[(r["case"], float(r["ramp"]))] = r
    for case in args.cases:
        scenario, n, extra = CASES[case]
        todo = {
            (case, ramp): (
                results_path(case, ramp),
                [*extra, f"fluid.collision.ramp={ramp!r}"],
                f"[{case} ramp {ramp:g}]",
            )
            for ramp in ramps
        }
        case_runner.finished_cases(
            scenario, todo, args.threads, args.analyse_only, args.retry_failed
        )
        for (_, ramp), (path, _, _) in todo.items():
            # a run that stopped (the gate without the ramp) is analysed up to its stop
            if not case_runner.analysable(case_runner.read_status(path)):
                continue
            row = {"case": case, "resolution_L_over_l0": n, "ramp": ramp, **run_row(path)}
            if case.startswith("gauge"):
                row.update(gauge_row(path, refs))
            else:  # the gate has no force probe of the obstacle's
                row.update(member_row(path, None if case.startswith("gate") else "obstacle_force"))
            rows[(case, ramp)] = row
    if not rows:
        print("nothing to analyse")
        return 1
    order = list(CASES)
    out = sorted(rows.values(), key=lambda r: (order.index(r["case"]), float(r["ramp"])))
    write_csv(
        out,
        CSV,
        COLUMNS,
        comment=(
            "collision ramp (fluid.collision.ramp) beside the hard threshold "
            "(validation/collision_ramp.py): far-wall gauge L/40 noise and front vs Koshizuka & "
            "Oka; elastic obstacle (mass ratio 0.103) and its stiff twin, tip peak, 1 ms force "
            "peak and ringing over 0.12-0.25 s, coupling iterations; rubber gate at 3 mm, rtol "
            "1e-4 (resolution column 0: not an L/l0 case)"
        ),
    )
    print_rows(out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
