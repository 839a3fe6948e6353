"""2D dam break against Koshizuka & Oka (1996) and Martin & Moyce (1952): the surge front's
resolution study (issue 2; references.md section 2).

Runs scenarios/dam_break_2d.toml at l0 = L/20, L/40, L/80 for 0.27 s (T = t sqrt(2 g / L) up to
3.1; each case an ``mpsfem run`` subprocess on NUMBA_NUM_THREADS threads, default 1, resumable
like every study in validation/), then writes

* docs/figures/dam_break_front_convergence.csv: per resolution the RMS relative error in Z over
  0.5 <= T <= 3 against both experiments, the best time offset and the error with it, Z at
  T = 1, 1.5, 2, 2.5, and the RMS difference to the next finer curve;
* docs/figures/dam_break_front_error_curve.csv: the error curve, the relative error in Z of
  every resolution at each experiment point with 0.5 <= T <= 3;
* docs/figures/dam_break_front_convergence.png: Z(T) of the three runs with both experiments,
  and the finest run shifted by its offset; below, the error curve;

and prints the table. Definitions: :func:`front_error`, :func:`time_offset`; discussion in
docs/fluid.md ("Validation status").

``--sensitivity`` runs instead the L/40 case once per model choice of :data:`VARIANTS` (the
defaults, the thesis's gradient and surface value, the original kernel, gamma, the wall model,
the Courant number, the collision distance; unstable variants are reported with the time they
stopped), and four realisations of the defaults that differ only in the CG tolerance (0.5-2e-6),
and writes docs/figures/dam_break_front_sensitivity.csv: does any choice of the method close the gap to the
experiments, beyond the metric's run-to-run noise?

``--stability`` runs instead the stability map: L/20 and L/40 at Courant numbers 0.1, 0.2 (the
default), 0.3, 0.4 and 0.5, and writes docs/figures/dam_break_stability.csv: which runs finish,
their wall time and front error (run time against error), and why the others stopped.

    python validation/dam_break.py [--threads 1] [--analyse-only] [--retry-failed]
                                   [--sensitivity | --stability]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import h5py
import numpy as np
from scipy.optimize import minimize_scalar

sys.path.insert(0, str(Path(__file__).resolve().parent))
import case_runner  # noqa: E402 - validation/case_runner.py: resumable runs of one case
from results_csv import write_csv  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
SCENARIO = ROOT / "scenarios" / "dam_break_2d.toml"
RESULTS_DIR = ROOT / "validation" / "results"
FIGURES_DIR = ROOT / "docs" / "figures"
REFERENCE_DIR = ROOT / "reference_data"  # copies of ../shared/reference-data, in the repository
REFERENCES = {
    "Koshizuka & Oka 1996": "dam_break_front_koshizuka_oka_1996.csv",
    "Martin & Moyce 1952": "dam_break_front_martin_moyce_1952.csv",
}

L = 0.146  # column width, m (references.md section 2)
G = 9.81  # m/s^2
RESOLUTIONS = (20, 40, 80)  # L / l0
END_TIME = 0.27  # s: T = 3.13, the front reaches the far wall (Z = 4) at T ~ 2.9
T_RANGE = (0.5, 3.0)  # the comparison window in T
TARGET = 0.10  # RMS relative error in Z (issue 2)
T_SCALE = float(np.sqrt(2.0 * G / L))  # T = t * T_SCALE


def read_reference(path: Path) -> np.ndarray:
    """(T, Z) rows of a reference CSV (comment lines start with #, then a header)."""
    return np.loadtxt(path, delimiter=",", comments="#", skiprows=3)


def front_curve(results: Path) -> tuple[np.ndarray, np.ndarray]:
    """(T, Z) of the ``front`` probe of a results file: T = t sqrt(2 g / L), Z = x / L."""
    with h5py.File(results, "r") as h5:
        t = h5["probes/front/time"][:]
        x = h5["probes/front/value"][:]
    return t * T_SCALE, x / L


def relative_errors(
    T: np.ndarray, Z: np.ndarray, reference: np.ndarray, shift: float = 0.0
) -> tuple[np.ndarray, np.ndarray]:
    """The reference points (T_ref, Z_ref) with 0.5 <= T <= 3 and the relative errors
    (Z_sim(T_ref - shift) - Z_ref) / Z_ref there: the error curve."""
    ref = reference[(reference[:, 0] >= T_RANGE[0]) & (reference[:, 0] <= T_RANGE[1])]
    return ref, (np.interp(ref[:, 0] - shift, T, Z) - ref[:, 1]) / ref[:, 1]


def front_error(T: np.ndarray, Z: np.ndarray, reference: np.ndarray, shift: float = 0.0) -> float:
    """RMS of :func:`relative_errors` (issue 2's metric at shift = 0)."""
    return float(np.sqrt(np.mean(relative_errors(T, Z, reference, shift)[1] ** 2)))


def time_offset(T: np.ndarray, Z: np.ndarray, reference: np.ndarray) -> tuple[float, float]:
    """The shift dT in [0, 1] (T units; dT / sqrt(2 g / L) in s) that minimises
    :func:`front_error`, and the error with it: how far the measured front lags the simulated
    one where both move at the same speed."""
    best = minimize_scalar(
        lambda s: front_error(T, Z, reference, s),
        bounds=(0.0, 1.0),
        method="bounded",
        options={"xatol": 1e-4},
    )
    return float(best.x), float(best.fun)


REFERENCE_KEYS = ("ko", "mm")  # column suffixes of REFERENCES, in order


def references() -> dict[str, np.ndarray]:
    """(T, Z) rows of each experiment of :data:`REFERENCES`."""
    return {name: read_reference(REFERENCE_DIR / f) for name, f in REFERENCES.items()}


def comparison(T: np.ndarray, Z: np.ndarray, refs: dict[str, np.ndarray]) -> dict[str, float]:
    """Per experiment (suffix ko / mm): the RMS error, the best time offset in T and in ms,
    and the error after it."""
    row = {}
    for key, ref in zip(REFERENCE_KEYS, refs.values(), strict=True):
        shift, shifted = time_offset(T, Z, ref)
        row[f"rms_error_{key}"] = front_error(T, Z, ref)
        row[f"offset_T_{key}"] = shift
        row[f"offset_ms_{key}"] = 1e3 * shift / T_SCALE
        row[f"rms_error_shifted_{key}"] = shifted
    return row


def curve_difference(
    fine: tuple[np.ndarray, np.ndarray], coarse: tuple[np.ndarray, np.ndarray]
) -> float:
    """RMS relative difference of two Z(T) curves over 0.5 <= T <= 2.8 (before the front
    reaches the far wall)."""
    grid = np.linspace(T_RANGE[0], 2.8, 47)
    zf, zc = np.interp(grid, *fine), np.interp(grid, *coarse)
    return float(np.sqrt(np.mean(((zf - zc) / zc) ** 2)))


SENSITIVITY_RESOLUTION = 40  # L / l0 of the model-choice study
#: (name, what it changes, --set overrides) of the model-choice study, defaults first
VARIANTS: tuple[tuple[str, str, tuple[str, ...]], ...] = (
    ("defaults", "the scenario's defaults", ()),
    (
        "gradient_pmin",
        "p_min gradient without the C_i^-1 correction",
        ('fluid.pressure.gradient="pmin"',),
    ),
    ("gradient_tanaka", "Tanaka's gradient (eq. 2-12)", ('fluid.pressure.gradient="tanaka"',)),
    ("surface_zero", "p = 0 at surface particles", ('fluid.surface.pressure="zero"',)),
    (
        "thesis",
        "thesis: p_min gradient, p = 0 at the surface, pressure wall layer",
        (
            'fluid.pressure.gradient="pmin"',
            'fluid.surface.pressure="zero"',
            'fluid.pressure.wall_model="pressure_layer"',
        ),
    ),
    (
        "wall_pressure_layer",
        "pressure wall layer instead of Neumann ghosts",
        ('fluid.pressure.wall_model="pressure_layer"',),
    ),
    ("kernel_original", "original kernel re/r - 1", ('fluid.kernel.weight="original"',)),
    ("gamma_0.05", "gamma = 0.05 (default 0.01)", ("fluid.pressure.gamma=0.05",)),
    ("courant_0.1", "Courant number 0.1 (default 0.2)", ("fluid.time_step.courant=0.1",)),
    ("no_collision", "collision model off", ("fluid.collision.enabled=false",)),
    ("collision_0.5", "collision distance 0.5 l0 (default 0.8)", ("fluid.collision.distance=0.5",)),
    ("collision_0.6", "collision distance 0.6 l0", ("fluid.collision.distance=0.6",)),
    ("collision_0.7", "collision distance 0.7 l0", ("fluid.collision.distance=0.7",)),
    # realisations: the CG tolerance moves the pressure in its last digits only; how far the
    # splash then carries that is the metric's own noise, the yardstick for the rows above
    (
        "cg_tol_0.5e-6",
        "realisation: CG tolerance 0.5e-6 (default 1e-6)",
        ("fluid.pressure.tol=5e-7",),
    ),
    ("cg_tol_0.8e-6", "realisation: CG tolerance 0.8e-6", ("fluid.pressure.tol=8e-7",)),
    ("cg_tol_1.25e-6", "realisation: CG tolerance 1.25e-6", ("fluid.pressure.tol=1.25e-6",)),
    ("cg_tol_2e-6", "realisation: CG tolerance 2e-6", ("fluid.pressure.tol=2e-6",)),
)


def case_path(n: int) -> Path:
    return RESULTS_DIR / f"dam_break_L{n}.h5"


def overrides(n: int) -> list[str]:
    return [f"fluid.spacing={L / n!r}", "output.snapshot_interval=0", f"run.end_time={END_TIME}"]


def variant_path(name: str) -> Path:
    return RESULTS_DIR / f"dam_break_L{SENSITIVITY_RESOLUTION}_{name}.h5"


def stop_time(results: Path) -> float:
    """Last time (s) of the front probe: where a failed run stopped."""
    with h5py.File(results, "r") as h5:
        t = h5["probes/front/time"][:]
    return float(t[-1]) if len(t) else 0.0


def sensitivity_rows(statuses: dict[str, str | None]) -> list[dict]:
    """One row per variant: the errors of a finished run, the stop time of a failed one."""
    refs = references()
    rows = []
    for name, what, _ in VARIANTS:
        status = statuses.get(name)
        path = variant_path(name)
        row: dict = {"variant": name, "change": what}
        if status == "finished":
            T, Z = front_curve(path)
            row["outcome"] = "finished"
            row.update(comparison(T, Z, refs))
            for t_probe in (1.0, 2.0):
                row[f"Z_T{t_probe:g}"] = float(np.interp(t_probe, T, Z))
        elif status is not None and path.is_file() and status.startswith("failed"):
            row["outcome"] = f"stopped at t = {stop_time(path):.3f} s"
        else:
            row["outcome"] = str(status)
        rows.append(row)
    return rows


def write_sensitivity(rows: list[dict]) -> Path:
    """docs/figures/dam_break_front_sensitivity.csv (numbers; blank where a run stopped)."""
    csv = FIGURES_DIR / "dam_break_front_sensitivity.csv"
    columns = ["variant", "change", "outcome"]
    for key in REFERENCE_KEYS:
        columns += [f"rms_error_{key}", f"offset_T_{key}", f"offset_ms_{key}"]
        columns.append(f"rms_error_shifted_{key}")
    columns += ["Z_T1", "Z_T2"]
    comment = (
        f"dam break front at l0 = L/{SENSITIVITY_RESOLUTION} per model choice, "
        "validation/dam_break.py --sensitivity: RMS relative error in Z over 0.5 <= T <= 3 "
        "against Koshizuka & Oka (ko) and Martin & Moyce (mm), best time offset, error after it"
    )
    write_csv(rows, csv, columns, comment)
    return csv


def run_sensitivity(threads: int, analyse_only: bool, retry: bool) -> int:
    """The model-choice study: run (or read) every variant, write the CSV, print the table."""
    statuses: dict[str, str | None] = {}
    base = overrides(SENSITIVITY_RESOLUTION)
    for name, _, extra in VARIANTS:
        out = variant_path(name)
        statuses[name] = case_runner.case_status(
            SCENARIO, out, base + list(extra), threads, analyse_only, retry, name
        )
    rows = sensitivity_rows(statuses)
    csv = write_sensitivity(rows)
    print(f"variant               error KO / MM      offset MM   shifted KO / MM   ({csv.name})")
    for r in rows:
        if r["outcome"] == "finished":
            print(
                f"{r['variant']:<20}  {100 * r['rms_error_ko']:5.1f} / {100 * r['rms_error_mm']:4.1f} %"
                f"    {r['offset_ms_mm']:5.1f} ms   {100 * r['rms_error_shifted_ko']:4.1f} / "
                f"{100 * r['rms_error_shifted_mm']:3.1f} %"
            )
        else:
            print(f"{r['variant']:<20}  {r['outcome']}")
    return 0 if all(s is not None for s in statuses.values()) else 1


STABILITY_RESOLUTIONS = (20, 40)  # L / l0 of the stability map
STABILITY_COURANT = (0.1, 0.2, 0.3, 0.4, 0.5)  # fluid.time_step.courant; 0.2 is the default


def stability_path(n: int, courant: float) -> Path:
    """The run of the stability map at L/n and Courant number ``courant``: runs of its own, the
    default's included, so that the wall times are of one code and one machine state (the
    default's front must equal the resolution study's run, bit for bit)."""
    return RESULTS_DIR / f"dam_break_stability_L{n}_C{courant:g}.h5"


def stability_overrides(n: int, courant: float) -> list[str]:
    return [*overrides(n), f"fluid.time_step.courant={courant:g}"]


def stability_rows(statuses: dict[tuple[int, float], str | None]) -> list[dict]:
    """One row per (resolution, Courant number): outcome, time reached, wall time, and for a
    finished run the front errors."""
    refs = references()
    rows = []
    for (n, courant), status in statuses.items():
        path = stability_path(n, courant)
        row: dict = {"resolution_L_over_l0": n, "courant": courant}
        if status is None or not path.is_file():
            row["outcome"] = str(status)
            rows.append(row)
            continue
        with h5py.File(path, "r") as h5:
            row["wall_time_s"] = float(h5.attrs.get("wall_time", np.nan))
        row["t_reached_s"] = stop_time(path)
        if status == "finished":
            row["outcome"] = "finished"
            T, Z = front_curve(path)
            row.update(comparison(T, Z, refs))
            row["Z_T2"] = float(np.interp(2.0, T, Z))
        else:
            row["outcome"] = status.split(" at t = ")[0][:120]
        rows.append(row)
    return rows


def run_stability(threads: int, analyse_only: bool, retry: bool) -> int:
    """The stability map: the dam break at L/20 and L/40 for Courant numbers 0.1 ... 0.5; does
    it finish, how fast, how accurate? Writes docs/figures/dam_break_stability.csv."""
    statuses: dict[tuple[int, float], str | None] = {}
    for n in STABILITY_RESOLUTIONS:
        for courant in STABILITY_COURANT:
            out = stability_path(n, courant)
            statuses[(n, courant)] = case_runner.case_status(
                SCENARIO,
                out,
                stability_overrides(n, courant),
                threads,
                analyse_only,
                retry,
                f"[L/{n} C={courant:g}]",
            )
    rows = stability_rows(statuses)
    csv = FIGURES_DIR / "dam_break_stability.csv"
    columns = ["resolution_L_over_l0", "courant", "outcome", "t_reached_s", "wall_time_s"]
    for key in REFERENCE_KEYS:
        columns += [f"rms_error_{key}", f"offset_T_{key}", f"offset_ms_{key}"]
        columns.append(f"rms_error_shifted_{key}")
    columns.append("Z_T2")
    comment = (
        "dam break stability map, validation/dam_break.py --stability: per resolution L/n and "
        "Courant number, the outcome (finished, or the reason the run stopped), the time "
        "reached, the wall time (1 thread) and the front's RMS relative error over "
        "0.5 <= T <= 3 against Koshizuka & Oka (ko) and Martin & Moyce (mm), unshifted and "
        "after the best time offset"
    )
    write_csv(rows, csv, columns, comment)
    print(f"L/l0  Courant  outcome           t (s)   wall (s)  error KO / MM   ({csv.name})")
    for r in rows:
        errors = (
            f"{100 * r['rms_error_ko']:5.1f} / {100 * r['rms_error_mm']:4.1f} %"
            if r["outcome"] == "finished"
            else ""
        )
        print(
            f"{r['resolution_L_over_l0']:>4}  {r['courant']:>7.2f}  {r['outcome'][:16]:<16}  "
            f"{r.get('t_reached_s', np.nan):6.3f}  {r.get('wall_time_s', np.nan):8.1f}  {errors}"
        )
    return 0 if all(s is not None for s in statuses.values()) else 1


def analyse(paths: dict[int, Path]) -> list[dict]:
    """One row per resolution: errors, offsets, Z at T = 1 ... 2.5, difference to the next finer
    curve, wall time."""
    refs = references()
    curves = {n: front_curve(p) for n, p in paths.items()}
    rows = []
    for n in sorted(curves):
        T, Z = curves[n]
        with h5py.File(paths[n], "r") as h5:
            wall = float(h5.attrs.get("wall_time", np.nan))
        row: dict = {"resolution_L_over_l0": n, "wall_time_s": wall}
        row.update(comparison(T, Z, refs))
        for t_probe in (1.0, 1.5, 2.0, 2.5):
            row[f"Z_T{t_probe:g}"] = float(np.interp(t_probe, T, Z))
        finer = [m for m in sorted(curves) if m > n]
        row["difference_to_finer"] = (
            curve_difference(curves[finer[0]], curves[n]) if finer else float("nan")
        )
        rows.append(row)
    return rows


def error_curves(paths: dict[int, Path]) -> list[dict]:
    """The error curve: per experiment point with 0.5 <= T <= 3, the relative error of every
    resolution (:func:`relative_errors`, the terms of :func:`front_error`)."""
    curves = {n: front_curve(p) for n, p in sorted(paths.items())}
    rows = []
    for key, reference in zip(REFERENCE_KEYS, references().values(), strict=True):
        errors = {n: relative_errors(T, Z, reference) for n, (T, Z) in curves.items()}
        points = next(iter(errors.values()))[0]
        for k, (T_ref, Z_ref) in enumerate(points):
            row: dict = {"experiment": key, "T": float(T_ref), "Z_ref": float(Z_ref)}
            for n, (_, rel) in errors.items():
                row[f"error_L{n}"] = float(rel[k])
            rows.append(row)
    return rows


def write_error_curves(rows: list[dict]) -> Path:
    """docs/figures/dam_break_front_error_curve.csv."""
    csv = FIGURES_DIR / "dam_break_front_error_curve.csv"
    comment = (
        "dam break front error curve, validation/dam_break.py: relative error "
        "(Z_sim - Z_ref) / Z_ref at each experiment point with 0.5 <= T <= 3, per resolution "
        "L/n; experiment ko = Koshizuka & Oka 1996, mm = Martin & Moyce 1952"
    )
    write_csv(rows, csv, comment=comment)
    return csv


def write_outputs(rows: list[dict], paths: dict[int, Path]) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    FIGURES_DIR.mkdir(parents=True, exist_ok=True)
    csv = FIGURES_DIR / "dam_break_front_convergence.csv"
    comment = (
        "dam break front (scenarios/dam_break_2d.toml), validation/dam_break.py: RMS relative "
        "error in Z over 0.5 <= T <= 3 against Koshizuka & Oka (ko) and Martin & Moyce (mm), "
        "unshifted and after the best time offset"
    )
    write_csv(rows, csv, comment=comment)
    errors = error_curves(paths)
    write_error_curves(errors)
    fig, (ax, ax_err) = plt.subplots(2, 1, figsize=(6.5, 7.0), height_ratios=(3, 2), sharex=True)
    for row in rows:
        n = row["resolution_L_over_l0"]
        T, Z = front_curve(paths[n])
        ax.plot(T, Z, label=f"MPS l0 = L/{n} (RMS error {100 * row['rms_error_ko']:.1f} %)")
    finest = rows[-1]
    T, Z = front_curve(paths[finest["resolution_L_over_l0"]])
    shift = finest["offset_T_mm"]
    ax.plot(
        T + shift,
        Z,
        "k--",
        lw=1,
        label=f"L/{finest['resolution_L_over_l0']} shifted by dT = {shift:.2f} "
        f"({finest['offset_ms_mm']:.0f} ms): {100 * finest['rms_error_shifted_mm']:.1f} % (M & M)",
    )
    markers = ("o", "s")
    for (name, f), m in zip(REFERENCES.items(), markers, strict=True):
        ref = read_reference(REFERENCE_DIR / f)
        ax.plot(ref[:, 0], ref[:, 1], m, mfc="k" if m == "o" else "none", mec="k", label=name)
    ax.set_xlim(0.0, 3.5)
    ax.set_ylim(1.0, 4.5)
    ax.set_ylabel("Z = x/L")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7.5)
    for i, row in enumerate(rows):  # the error curve: the terms of the RMS error
        n = row["resolution_L_over_l0"]
        for key, m in zip(REFERENCE_KEYS, markers, strict=True):
            pts = [e for e in errors if e["experiment"] == key]
            ax_err.plot(
                [e["T"] for e in pts],
                [100 * e[f"error_L{n}"] for e in pts],
                m + "-",
                color=f"C{i}",
                mfc=f"C{i}" if m == "o" else "none",
                lw=1,
                label=f"L/{n}" if key == REFERENCE_KEYS[0] else None,
            )
    ax_err.axhline(100 * TARGET, color="k", ls=":", lw=1, label="issue target (RMS)")
    ax_err.axhline(0.0, color="k", lw=0.5)
    ax_err.set_xlabel("T = t sqrt(2g/L)")
    ax_err.set_ylabel("(Z - Z_exp) / Z_exp (%)")
    ax_err.set_title("error at the experiment points: filled K & O, open M & M", fontsize=8)
    ax_err.grid(alpha=0.3)
    ax_err.legend(fontsize=7.5, ncol=4)
    fig.tight_layout()
    fig.savefig(FIGURES_DIR / "dam_break_front_convergence.png", dpi=110)
    plt.close(fig)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    case_runner.add_run_options(ap)
    ap.add_argument(
        "--sensitivity",
        action="store_true",
        help=f"the model-choice study at L/{SENSITIVITY_RESOLUTION} instead of the resolution study",
    )
    ap.add_argument(
        "--stability",
        action="store_true",
        help="the stability map (Courant number 0.1-0.5 at L/20 and L/40) instead",
    )
    args = ap.parse_args(argv)
    RESULTS_DIR.mkdir(parents=True, exist_ok=True)
    if args.stability:
        return run_stability(args.threads, args.analyse_only, args.retry_failed)
    if args.sensitivity:
        return run_sensitivity(args.threads, args.analyse_only, args.retry_failed)
    cases = {n: (case_path(n), overrides(n), f"[L/{n}]") for n in RESOLUTIONS}
    paths = case_runner.finished_cases(
        SCENARIO, cases, args.threads, args.analyse_only, args.retry_failed
    )
    if not paths:
        print("nothing to analyse")
        return 1
    rows = analyse(paths)
    write_outputs(rows, paths)
    print("L/l0  error KO   error MM   offset (T, ms)     error shifted KO / MM   ", end="")
    print("diff. to finer  wall")
    for r in rows:
        print(
            f"{r['resolution_L_over_l0']:>4}  {100 * r['rms_error_ko']:6.2f} %  "
            f"{100 * r['rms_error_mm']:6.2f} %  {r['offset_T_mm']:.3f} ({r['offset_ms_mm']:.1f})"
            f"      {100 * r['rms_error_shifted_ko']:.2f} / {100 * r['rms_error_shifted_mm']:.2f} %"
            f"         {100 * r['difference_to_finer']:.2f} %      {r['wall_time_s']:.0f} s"
        )
    met = all(r["rms_error_ko"] <= TARGET for r in rows)
    print(f"issue target (RMS <= {TARGET:.0%} unshifted): {'met' if met else 'not met'}")
    return 0 if len(paths) == len(RESOLUTIONS) else 1


if __name__ == "__main__":
    sys.exit(main())
