"""Water entry of the seed paper's elastic steel plate, and the entry-speed stress sweep.

Case: scenarios/plate_water_entry_2d.toml (seed paper /work/shared/seeds/
paper_mps_elastic_plate_water_entry.txt: steel, rho 7800 kg/m^3, E 2.1e11 Pa, nu 0.3, entry at
6.28 m/s, l0 = 0.01 m, dt = 2e-6 s, gamma = 0.01; the rest is ours, stated in the scenario).

What it measures, per case (docs/validation_plate_water_entry.md):

* the impact impulse J(t) = int_0^t F_y dt of the fluid force on the plate (probe "slam_force",
  interval means, so the samples integrate to the impulse exactly), at t_c + 0.1, 0.5, 1, 3 ms,
  t_c = the geometric contact time (the plate's particles one l0 above the top fluid row);
  against von Karman's (1929) momentum of the flat plate's added mass, J_ref = m_a V with the
  high-frequency free-surface added mass of a flat plate of width L, m_a = rho pi L^2 / 8
  (half the infinite-fluid value rho pi (L/2)^2; Faltinsen 1990, Sea Loads, ch. 9). The
  incompressible pressure peak of a flat impact does not converge (it grows as dt and l0 shrink),
  so the impulse is the compared quantity; the peak force is printed for the record only;
* the peak force F_y,max (sample means over 2e-5 s) and the mean bottom pressure F_y,max / L;
* the elastic mid-span deflection w = y_mid - y_support (probes "plate_mid", "plate_support",
  absolute; positive upwards), its largest value and when;
* the wall time and the run's final status (finished, or the named error that stopped it).

Case ``pressure`` (``pressure_stiff``: E x 1000): the seed set-up to t_c + 1 ms, for the plate
pressure probes that ride with the plate on its wetted face ("p_centre" at x = 0, "p_quarter" at
x = L/4, each the mean of 4 face particles, sampled every step): the pressure impulse
int p dt against the flat-plate impact impulse rho V sqrt((L/2)^2 - x^2) (von Karman 1929;
Faltinsen 1990), its shape (centre / mean, quarter / centre) and the centre's peak, which does
not converge (the impulse is compared). Its own CSV: plate_water_entry_pressure.csv.

Case ``dt`` (time-step sensitivity): the ``pressure`` case at the seed's dt = 2e-6 s and at
1e-6 s (fluid step, structure step and coupling window halved together, the pressure probes
sampled every step), to t_c + 1 ms: the force impulse, the plate-pressure impulses, the peaks and
the deflection at t_c + 0.1, 0.5 and 1 ms, each dt's value and their relative change. Its own
CSV: plate_water_entry_dt.csv.

The seed paper's Table 1 (peak plate-centre pressures, experiment and MPS, several speeds) and
Figs. 5-6 (centre pressure and deflection histories at 6.28 m/s) are images that our copy of the
paper lacks: no number of theirs can be quoted, and the CSV says so.

Usage: ``python validation/plate_water_entry.py [--cases seed,sweep] [--analyse-only]``;
results files under validation/results/ (plate_water_entry_v<V>.h5), numbers to
validation/results/plate_water_entry.csv.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import h5py
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import case_runner  # noqa: E402 - validation/case_runner.py: resumable runs of one case
from results_csv import write_csv  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
SCENARIO = ROOT / "scenarios" / "plate_water_entry_2d.toml"
RESULTS_DIR = ROOT / "validation" / "results"

RHO = 1000.0  # water, kg/m^3
L = 0.4  # plate span, m
L0 = 0.01  # particle spacing, m
Y_PLATE = 0.52  # plate centreline (= its particle row) at t = 0, m
Y_TOP_FLUID = 0.5 - L0 / 2  # top fluid row, m
SEED_SPEED = 6.28  # m/s
SWEEP = (1.0, 6.28, 15.0, 30.0)  # m/s
SEED_END = 0.01  # s
SWEEP_AFTER_CONTACT = 1.5e-3  # sweep cases run this long past contact, s
STIFF_AFTER_CONTACT = 3e-3  # the stiff control runs this long past contact, s


#: start height of the plate's centreline for a speed other than the scenario's 2.5 l0 above
#: the top fluid row: at 1 m/s, 1.25 l0 (the force's onset in the 6.28, 15 and 30 m/s runs came
#: at a gap of 1.05 l0, so the water still does not feel the plate at t = 0), to spare 12 ms of
#: flight through air on the shared machine
START_Y = {1.0: Y_TOP_FLUID + 1.25 * L0}


def plate_y(v: float) -> float:
    return START_Y.get(v, Y_PLATE)


def contact_time(v: float) -> float:
    """Geometric contact: the plate's particles one l0 above the top fluid row, s."""
    return (plate_y(v) - Y_TOP_FLUID - L0) / v


def added_mass() -> float:
    """Flat plate of width L on the free surface, high-frequency limit: rho pi (L/2)^2 / 2 (kg/m)."""
    return RHO * math.pi * L * L / 8.0  # von Karman 1929; Faltinsen 1990, ch. 9


#: the "rigid" control: the same plate 1000 times stiffer (first mode 10.5 kHz, period 95 us)
STIFF_FACTOR = 1000.0


def case_path(v: float, rigid: bool = False, corotational: bool = False) -> Path:
    tag = "_stiff" if rigid else ("_corotational" if corotational else "")
    return RESULTS_DIR / f"plate_water_entry_v{v:g}{tag}.h5"


def overrides(v: float, end: float, rigid: bool = False, corotational: bool = False) -> list[str]:
    out = [f"structure.members.0.motion.velocity={v!r}", f"run.end_time={end!r}"]
    y = plate_y(v)
    if y != Y_PLATE:  # the member and the probes on it
        out += [
            f"structure.members.0.start=[{-L / 2!r}, {y!r}]",
            f"structure.members.0.end=[{L / 2!r}, {y!r}]",
            f"probes.1.position=[0.0, {y!r}]",
            f"probes.2.position=[{-L / 2!r}, {y!r}]",
        ]
    if rigid:
        out.append(f"structure.members.0.material.youngs_modulus={2.1e11 * STIFF_FACTOR!r}")
    if corotational:
        out.append('structure.members.0.kinematics="corotational"')
    return out


def analyse(path: Path, v: float, seed: bool, case: str | None = None) -> dict:
    row: dict = {"case": case or ("seed" if seed else "sweep"), "speed": v}
    with h5py.File(path, "r") as h5:
        row["status"] = str(h5.attrs.get("status", "unknown"))
        row["wall_time_s"] = float(h5.attrs.get("wall_time", float("nan")))
        if "probes/slam_force/time" not in h5:
            return row
        t = h5["probes/slam_force/time"][()]
        f = h5["probes/slam_force/value"][()][:, 1]
        tm = h5["probes/plate_mid/time"][()]
        w = h5["probes/plate_mid/value"][()][:, 1] - h5["probes/plate_support/value"][()][:, 1]
        it = h5["coupling/iterations"][()]
    tc = contact_time(v)
    row["t_contact_ms"] = tc * 1e3
    row["t_end_ms"] = float(t[-1]) * 1e3
    # samples are interval means: impulse = sum of mean x interval (the first covers [0, t0])
    dt = np.diff(np.concatenate([[0.0], t]))
    J = np.cumsum(f * dt)
    ref = added_mass() * v
    row["J_ref_Ns_per_m"] = ref
    for tau in (0.1e-3, 0.5e-3, 1e-3, 3e-3):
        key = f"J_{tau * 1e3:g}ms"
        if t[-1] >= tc + tau - 1e-12:
            row[key] = float(np.interp(tc + tau, t, J))
            row[f"{key}_over_ref"] = row[key] / ref
    k = int(np.argmax(f))
    row["F_peak_N_per_m"] = float(f[k])
    row["t_F_peak_ms"] = float(t[k]) * 1e3
    row["p_mean_peak_Pa"] = float(f[k]) / L
    j = int(np.argmax(w))
    row["w_max_mm"] = float(w[j]) * 1e3
    row["t_w_max_ms"] = float(tm[j]) * 1e3
    row["w_min_mm"] = float(w.min()) * 1e3
    row["coupling_iterations_mean"] = float(np.mean(it))
    row["coupling_iterations_max"] = int(np.max(it))
    row["paper"] = "Table 1 / Figs. 5-6: images, no numbers in the seed's text"
    return row


#: the plate-pressure case: the seed set-up to about t_c + 1 ms (docs: the run's length)
PRESSURE_END = 0.0034  # s
#: the attached pressure probes on the wetted face (scenario "p_centre", "p_quarter"): reference
#: x (m) and the x of the four particles each averages (1 l0 around it, particles at half spacings)
PRESSURE_PROBES = {"centre": 0.0, "quarter": 0.1}
SOUND_SPEED = 1500.0  # water, m/s: the acoustic bound rho c V of a compressible flat impact


def pressure_impulse_ref(x: float, v: float) -> float:
    """Flat-plate impact pressure impulse at x (Pa s), averaged over the probe's four particles:
    P(x) = rho V sqrt((L/2)^2 - x^2), the potential of the plate's added-mass flow at impact
    (von Karman 1929; Faltinsen 1990, Sea Loads, ch. 9: phi = -V sqrt(c^2 - x^2), P = -rho phi);
    its integral over the span is rho V pi L^2 / 8 = J_ref."""
    xs = x + np.array([-1.5, -0.5, 0.5, 1.5]) * L0
    return float(np.mean(RHO * v * np.sqrt((L / 2) ** 2 - xs**2)))


def analyse_pressure(path: Path, v: float) -> dict:
    """Plate-centre and quarter-span pressure of the attached probes: impulses int p dt from 0
    (the probes read 0 in air) to t_c + tau against :func:`pressure_impulse_ref`, their ratio
    against the force impulse's mean pressure J / L (theory: 4 / pi at the centre), the
    quarter/centre ratio (theory sqrt(3)/2), and the centre's peak for the record."""
    row: dict = {"case": "pressure", "speed": v}
    with h5py.File(path, "r") as h5:
        row["status"] = str(h5.attrs.get("status", "unknown"))
        row["wall_time_s"] = float(h5.attrs.get("wall_time", float("nan")))
        tp = h5["probes/p_centre/time"][()]
        pc = h5["probes/p_centre/value"][()]
        pq = h5["probes/p_quarter/value"][()]
        tf = h5["probes/slam_force/time"][()]
        f = h5["probes/slam_force/value"][()][:, 1]
    tc = contact_time(v)
    row["t_contact_ms"] = tc * 1e3
    row["t_end_ms"] = float(tp[-1]) * 1e3
    row["t_onset_ms"] = float(tp[np.argmax(pc > 0.0)]) * 1e3
    # samples every step (interval = dt): trapezoidal int p dt; the force samples are means
    jf = np.cumsum(f * np.diff(np.concatenate([[0.0], tf])))
    cum = {}
    for name, p in (("centre", pc), ("quarter", pq)):
        cum[name] = np.concatenate([[0.0], np.cumsum(0.5 * (p[1:] + p[:-1]) * np.diff(tp))])
        row[f"P_ref_{name}_Pa_s"] = pressure_impulse_ref(PRESSURE_PROBES[name], v)
    for tau in (0.1e-3, 0.5e-3, 1e-3):
        if tp[-1] < tc + tau - 1e-12:
            continue
        ms = f"{tau * 1e3:g}ms"
        for name in PRESSURE_PROBES:
            val = float(np.interp(tc + tau, tp, cum[name]))
            row[f"P_{name}_{ms}"] = val
            row[f"P_{name}_{ms}_over_ref"] = val / row[f"P_ref_{name}_Pa_s"]
        mean_p = float(np.interp(tc + tau, tf, jf)) / L
        row[f"P_centre_{ms}_over_J_per_L"] = row[f"P_centre_{ms}"] / mean_p
        row[f"P_quarter_over_centre_{ms}"] = row[f"P_quarter_{ms}"] / row[f"P_centre_{ms}"]
    row["P_centre_over_J_per_L_theory"] = 4.0 / math.pi
    row["P_quarter_over_centre_theory"] = math.sqrt(3.0) / 2.0
    k = int(np.argmax(pc))
    row["p_centre_peak_Pa"] = float(pc[k])
    row["t_p_centre_peak_ms"] = float(tp[k]) * 1e3
    row["p_centre_peak_impulse_Pa_s"] = float(pc[k]) * float(np.median(np.diff(tp)))
    row["rho_c_V_Pa"] = RHO * SOUND_SPEED * v  # acoustic bound, not reached by a physical peak
    row["rho_V_l0_over_dt_Pa"] = RHO * v * L0 / float(np.median(np.diff(tp)))
    return row


#: the time steps of the sensitivity study (case ``dt``), s: the seed's and half of it
DT_STUDY = (2e-6, 1e-6)
#: indices of the attached pressure probes in the scenario's [[probes]] (their interval = dt)
PRESSURE_PROBE_INDEX = (3, 4)


def dt_case(dt: float) -> tuple[Path, list[str]]:
    """Results file and overrides of the dt study's run at step ``dt``: the ``pressure`` case
    (seed set-up to t_c + 1 ms) with the fluid step, the structure step (hence the coupling
    window) and the pressure probes' interval set to ``dt``; at the seed's 2e-6 s it is the
    ``pressure`` case itself (same file)."""
    ov = overrides(SEED_SPEED, PRESSURE_END)
    if dt == 2e-6:
        return RESULTS_DIR / "plate_water_entry_v6.28_probes.h5", ov
    ov += [f"fluid.time_step.dt_max={dt!r}", f"structure.time.dt={dt!r}"]
    ov += [f"probes.{i}.interval={dt!r}" for i in PRESSURE_PROBE_INDEX]
    return RESULTS_DIR / f"plate_water_entry_v6.28_probes_dt{dt * 1e6:g}.h5", ov


def analyse_dt(path: Path, dt: float) -> dict:
    """One row of the dt study: force impulse, peak force and deflection (:func:`analyse`), the
    plate-pressure impulses and the centre's peak (:func:`analyse_pressure`), and the elastic
    deflection w at t_c + 0.1, 0.5, 1 ms."""
    v = SEED_SPEED
    a = analyse(path, v, False, case="dt")
    b = analyse_pressure(path, v)
    row: dict = {"case": "dt", "dt_s": dt, "speed": v, "status": a["status"]}
    row["wall_time_s"] = a["wall_time_s"]
    for tau in ("0.1ms", "0.5ms", "1ms"):
        row[f"J_{tau}"] = a.get(f"J_{tau}", math.nan)
        row[f"J_{tau}_over_ref"] = a.get(f"J_{tau}_over_ref", math.nan)
        for name in PRESSURE_PROBES:
            row[f"P_{name}_{tau}"] = b.get(f"P_{name}_{tau}", math.nan)
    with h5py.File(path, "r") as h5:
        tm = h5["probes/plate_mid/time"][()]
        w = h5["probes/plate_mid/value"][()][:, 1] - h5["probes/plate_support/value"][()][:, 1]
    tc = contact_time(v)
    for tau in (0.1e-3, 0.5e-3, 1e-3):
        row[f"w_{tau * 1e3:g}ms_mm"] = float(np.interp(tc + tau, tm, w)) * 1e3
    for key in ("F_peak_N_per_m", "t_F_peak_ms", "coupling_iterations_mean"):
        row[key] = a[key]
    row["coupling_iterations_max"] = a["coupling_iterations_max"]
    for key in ("p_centre_peak_Pa", "t_p_centre_peak_ms", "p_centre_peak_impulse_Pa_s"):
        row[key] = b[key]
    row["rho_V_l0_over_dt_Pa"] = b["rho_V_l0_over_dt_Pa"]
    return row


def dt_study(threads: int, analyse_only: bool, retry: bool) -> list[dict]:
    """Run (or read) the dt study's cases; rows of the finished ones, and for each quantity of
    the finest row its relative change from the seed's dt (``<key>_change``, in the last row)."""
    rows = []
    for dt in DT_STUDY:
        out, ov = dt_case(dt)
        status = case_runner.case_status(
            SCENARIO, out, ov, threads, analyse_only, retry, tag=f"dt = {dt:g} s"
        )
        print(f"dt = {dt:g} s: {status}")
        if status == "finished":
            rows.append(analyse_dt(out, dt))
    if len(rows) == 2:
        base, fine = rows
        for key in [k for k in base if k.startswith(("J_", "P_", "w_", "F_peak", "p_centre"))]:
            if isinstance(base[key], float) and base[key] != 0.0:
                fine[f"{key}_change"] = fine[key] / base[key] - 1.0
    return rows


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "--cases",
        default="seed,sweep",
        help="comma list of seed, sweep, stiff (the seed case with a 1000 times stiffer plate), "
        "corotational (the 30 m/s sweep case with a co-rotational, large-rotation member), "
        "pressure (the seed case to t_c + 1 ms for the plate pressure probes; its own CSV, "
        "plate_water_entry_pressure.csv), pressure_stiff (the same, E x 1000), dt (the "
        "pressure case at dt = 2e-6 and 1e-6 s; its own CSV, plate_water_entry_dt.csv)",
    )
    case_runner.add_run_options(ap)
    a = ap.parse_args(argv)
    which = set(a.cases.split(","))
    RESULTS_DIR.mkdir(parents=True, exist_ok=True)
    plan: list[tuple[float, float, bool, bool]] = []  # speed, end time, seed?, stiff?
    corot = "corotational" in which
    if "seed" in which:
        plan.append((SEED_SPEED, SEED_END, True, False))
    if "stiff" in which:
        plan.append((SEED_SPEED, contact_time(SEED_SPEED) + STIFF_AFTER_CONTACT, False, True))
    if "sweep" in which:
        for v in SWEEP:
            if v == SEED_SPEED and "seed" in which:
                continue  # the seed run is the sweep's 6.28 m/s case
            plan.append((v, contact_time(v) + SWEEP_AFTER_CONTACT, False, False))
    pressure_cases = [c for c in ("pressure", "pressure_stiff") if c in which]
    prows = []
    for c in pressure_cases:
        stiff = c == "pressure_stiff"
        out = RESULTS_DIR / f"plate_water_entry_v6.28_probes{'_stiff' if stiff else ''}.h5"
        status = case_runner.case_status(
            SCENARIO,
            out,
            overrides(SEED_SPEED, PRESSURE_END, rigid=stiff),
            a.threads,
            a.analyse_only,
            a.retry_failed,
            tag=c,
        )
        print(f"{c}: {status}")
        if status == "finished":
            prows.append({**analyse_pressure(out, SEED_SPEED), "case": c})
        which.discard(c)
    for r in prows:
        print(
            ", ".join(
                f"{k} = {v:.4g}" if isinstance(v, float) else f"{k} = {v}" for k, v in r.items()
            )
        )
    if prows:
        write_csv(
            prows,
            RESULTS_DIR / "plate_water_entry_pressure.csv",
            list(prows[0]),
            comment="validation/plate_water_entry.py --cases pressure[,pressure_stiff]: "
            "plate-centre and quarter-span pressure (attached probes on the wetted face); "
            "P = int p dt in Pa s from t = 0 to t_c + tau, ref rho V sqrt((L/2)^2 - x^2)",
        )
    if "dt" in which:
        drows = dt_study(a.threads, a.analyse_only, a.retry_failed)
        for r in drows:
            print(
                ", ".join(
                    f"{k} = {v:.4g}" if isinstance(v, float) else f"{k} = {v}" for k, v in r.items()
                )
            )
        if drows:
            cols: list[str] = []
            for r in drows:
                cols += [k for k in r if k not in cols]
            write_csv(
                drows,
                RESULTS_DIR / "plate_water_entry_dt.csv",
                cols,
                comment="validation/plate_water_entry.py --cases dt: time-step sensitivity of "
                "the seed case to t_c + 1 ms (dt = fluid step = structure step = window); J in "
                "N s/m, P = int p dt in Pa s, w in mm; *_change = value at 1e-6 s over 2e-6 s - 1",
            )
        which.discard("dt")
    if (pressure_cases or "dt" in a.cases.split(",")) and not which:
        return 0
    rows = []
    if corot:
        plan.append((30.0, contact_time(30.0) + SWEEP_AFTER_CONTACT, False, False))
    for k, (v, end, seed, stiff) in enumerate(plan):
        co = corot and k == len(plan) - 1
        out = case_path(v, stiff, co)
        t0 = time.perf_counter()
        status = case_runner.case_status(
            SCENARIO,
            out,
            overrides(v, end, stiff, co),
            a.threads,
            a.analyse_only,
            a.retry_failed,
            tag=f"V = {v:g} m/s",
        )
        print(f"V = {v:g} m/s: {status} ({time.perf_counter() - t0:.0f} s here)")
        if status is None or status == "locked" or not out.is_file():
            case = "corotational" if co else ("stiff" if stiff else ("seed" if seed else "sweep"))
            rows.append({"case": case, "speed": v, "status": status})
            continue
        rows.append(analyse(out, v, seed, "corotational" if co else ("stiff" if stiff else None)))
        if "seed" in which and "sweep" in which and seed:
            rows.append({**rows[-1], "case": "sweep"})
    for r in rows:
        print(
            ", ".join(
                f"{k} = {v:.4g}" if isinstance(v, float) else f"{k} = {v}" for k, v in r.items()
            )
        )
    cols: list[str] = []
    for r in rows:
        cols += [k for k in r if k not in cols]
    write_csv(
        rows,
        RESULTS_DIR / "plate_water_entry.csv",
        cols,
        comment="validation/plate_water_entry.py: elastic steel plate water entry (seed paper) "
        "and the entry-speed sweep; J in N s/m, F in N/m, w in mm (elastic, + up)",
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
