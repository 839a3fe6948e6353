"""The fluid's momentum budget over impacts, and what walls and members are told they feel
(issue "Interface loads that conserve momentum and do not ring").

Cases (each an ``mpsfem run`` subprocess, resumable like every study in validation/):

* the elastic obstacle (scenarios/dam_break_elastic_obstacle_2d.toml) at l0 = L/20 and L/40 to
  0.25 s, with the structure loaded by ``fluid.boundary_force = "pressure_integral"`` (thesis
  eq. 2-51, the earlier default) and ``"pressure_and_contact"`` (eq. 2-51 plus the viscous and
  collision exchange); the impact window is 0.12-0.25 s;
* the Koshizuka-Oka dam break (scenarios/dam_break_2d.toml) at L/40 to 0.4 s: the column's
  collapse (0-0.2 s) and the impact on the far wall (0.2-0.4 s); a fluid-only run, so every
  force model's numbers come from the one run's budget;
* the antisymmetric gradients (``tanaka``, ``cmps``, with ``momentum_exchange``), which close
  the budget to round-off (tests/fluid_mps/test_momentum_budget.py), on still water
  (scenarios/hydrostatic_2d.toml, 0.5 s) and the dam break at L/40: do they run?
* the stabilised conservative option: ``tanaka`` with its stiffness time-step limit
  ``fluid.pressure.pressure_courant = 0.25`` and ``momentum_exchange`` (:data:`LIMITED`), with
  and without particle shifting (``fluid.pressure.shifting = 0.1``; the default with shifting
  too, on the dam break), on
  still water for 2 s (gauge mean over 1-2 s against rho g (H - 0.05) = 4414.5 Pa, velocity
  RMS, highest particle), the dam break at L/40 to 0.4 s (budget, front error against both
  experiments as validation/dam_break.py defines it, the far-wall gauge's noise as
  validation/dam_break_wall_gauge.py defines it; the default run's figures beside it) and
  the elastic obstacle at L/20 (budget, tip, ringing), and at L/40 without shifting (the
  issue's budget target names both resolutions);

Per case and window, from ``/momentum_budget`` (impulses in N s/m):

* the fluid's momentum change, gravity's impulse, the internal imbalance of the pressure pairs;
* per patch the reported impulse under each force model;
* ``residual_external`` = dP - G - S + sum_b J_b: what the reported boundary impulses J_b leave
  unexplained of the fluid's momentum change (gravity G, sponge S), per component and relative
  to sum_b |J_b|; and the issue's ``residual`` (the same with the internal imbalance counted
  as a further source);
* obstacle: the impulse the member is handed, the collision model's share of it, the peak tip
  displacement and its time, and the ringing of the force probe at 1 ms sampling (RMS of the
  sample-to-sample jump over its peak) for the last-step force (``average = false``) and for
  the interval mean (``average = true``).

Writes validation/results/momentum_budget.csv and prints the table; discussed in docs/fluid.md
("Momentum budget") and docs/validation.md.

    python validation/momentum_budget.py [--threads 1] [--analyse-only] [--retry-failed]
                                         [--only NAME ...]

``--only``: the cases whose results file name contains one of the strings (e.g.
``momentum_obstacle_L40_tanaka``, the limited Tanaka obstacle at L/40); the CSV keeps every other
row as it was (the study's results files are not kept in the repository).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import h5py
import numpy as np
from scipy.signal import savgol_filter

sys.path.insert(0, str(Path(__file__).resolve().parent))
import case_runner  # noqa: E402 - validation/case_runner.py: resumable runs of one case
from results_csv import read_csv, write_csv  # noqa: E402

ROOT = case_runner.ROOT
RESULTS_DIR = ROOT / "validation" / "results"
OBSTACLE = ROOT / "scenarios" / "dam_break_elastic_obstacle_2d.toml"
DAM = ROOT / "scenarios" / "dam_break_2d.toml"
STILL = ROOT / "scenarios" / "hydrostatic_2d.toml"
L = 0.146  # m, the column width of both dam breaks
MODELS = ("pressure_integral", "pressure_and_contact")
#: an instantaneous twin of the obstacle's force probe (the scenario's own one averages),
#: appended to a copy of the scenario (--set cannot add a list item)
INSTANT_PROBE = """
[[probes]]
name = "force_last_step"
kind = "force"
target = "obstacle"
average = false
"""
WINDOWS = {
    "obstacle": [("impact", 0.12, 0.25)],
    "dam_break": [("collapse", 0.0, 0.2), ("impact", 0.2, 0.4)],
}


def obstacle_cases() -> dict:
    cases = {}
    for n in (20, 40):
        for model in MODELS:
            sets = [
                f"fluid.spacing={L / n:.6g}",
                "run.end_time=0.25",
                f"fluid.boundary_force={model}",
                "output.snapshot_interval=0",
            ]
            out = RESULTS_DIR / f"momentum_obstacle_L{n}_{model}.h5"
            cases[("obstacle", n, model)] = (out, sets, f"[obstacle L/{n} {model}]")
    return cases


def dam_cases() -> dict:
    sets = ["fluid.spacing=0.00365", "run.end_time=0.4", "output.probe_interval=0.001"]
    out = RESULTS_DIR / "momentum_dam_break_L40.h5"
    return {("dam_break", 40, "fluid_only"): (out, sets, "[dam break L/40]")}


#: the stabilised conservative option: Tanaka's antisymmetric gradient under the time-step
#: limit of its p_i + p_j repulsion (docs/fluid.md), loads by momentum exchange
LIMITED = [
    "fluid.pressure.gradient=tanaka",
    "fluid.pressure.pressure_courant=0.25",
    "fluid.boundary_force=momentum_exchange",
]


#: the variants of :func:`limited_cases`: their overrides and the force model they report
SHIFTING = ["fluid.pressure.shifting=0.1"]
VARIANTS = {
    "default": ([], "pressure_and_contact"),
    "default_shifting": (SHIFTING, "pressure_and_contact, shifting 0.1"),
    "tanaka_limited": (LIMITED, "momentum_exchange, tanaka limited"),
    "tanaka_limited_shifting": (
        [*LIMITED, *SHIFTING],
        "momentum_exchange, tanaka limited, shifting 0.1",
    ),
}
LIMITED_RUNS = {
    "still_water": ("default", "default_shifting", "tanaka_limited", "tanaka_limited_shifting"),
    "dam_break": ("default_shifting", "tanaka_limited", "tanaka_limited_shifting"),
    "obstacle": ("tanaka_limited", "tanaka_limited_shifting"),
    "obstacle_L40": ("tanaka_limited",),  # the budget target at L/40 too
}


def limited_cases() -> dict:
    """(case, L / l0, variant) -> (results path, overrides, tag) of the limited Tanaka study
    (the dam break's and the obstacle's default runs are :func:`dam_cases` and
    :func:`obstacle_cases`)."""
    base = {
        "still_water": (0, "momentum_still", ["run.end_time=2.0"]),
        "dam_break": (40, "momentum_dam_break_L40", dam_cases()[("dam_break", 40, "fluid_only")][1]),
        "obstacle": (20, "momentum_obstacle_L20", [f"fluid.spacing={L / 20:.6g}", "run.end_time=0.25"]),
        "obstacle_L40": (40, "momentum_obstacle_L40", [f"fluid.spacing={L / 40:.6g}", "run.end_time=0.25"]),
    }  # fmt: skip
    cases = {}
    for name, variants in LIMITED_RUNS.items():
        n, stem, sets = base[name]
        case = name.split("_L")[0]  # obstacle_L40 is the obstacle case at L/40
        for variant in variants:
            extra = VARIANTS[variant][0]
            cases[(case, n, variant)] = (
                RESULTS_DIR / f"{stem}_{variant}.h5",
                [*extra, *sets, "output.snapshot_interval=0"],
                f"[{name} {variant}]",
            )
    return cases


def dam_quality(path: Path) -> dict:
    """The front's RMS error against both experiments, raw and after the best time offset
    (validation/dam_break.py), and the far-wall gauge's noise (dam_break_wall_gauge.py)."""
    import dam_break
    import dam_break_wall_gauge

    T, Z = dam_break.front_curve(path)
    row = dam_break.comparison(T, Z, dam_break.references())
    stats = dam_break_wall_gauge.gauge_statistics(*dam_break_wall_gauge.read_gauge(path))
    with h5py.File(path, "r") as h5:
        row["steps"] = len(h5["momentum_budget/time"])
        row["wall_time_s"] = float(h5.attrs.get("wall_time", np.nan))
    return row | {"gauge_noise_rel": stats.noise_relative, "gauge_peak_pa": stats.peak_pa}


def still_row(path: Path, model: str) -> dict:
    """Still water over 1-2 s: the gauge's mean against rho g (H - 0.05), the fluid's velocity
    RMS (from the kinetic energy) and the highest particle."""
    with h5py.File(path, "r") as h5:
        t = h5["probes/gauge/time"][:]
        p = h5["probes/gauge/value"][:]
        te = h5["probes/energy/time"][:]
        e = h5["probes/energy/value"][:]
        wall = float(h5.attrs.get("wall_time", np.nan))
        steps = len(h5["momentum_budget/time"])
    sel = (t >= 1.0) & (t <= 2.0)
    sel_e = (te >= 1.0) & (te <= 2.0)
    mass = 1000.0 * 0.4 * 0.5  # kg/m, rho W H
    return {
        "case": "still_water",
        "resolution_L_over_l0": 0,
        "force_model": model,
        "window": "1-2 s",
        "t0_s": 1.0,
        "t1_s": 2.0,
        "gauge_mean_error_rel": float(p[sel].mean() / 4414.5 - 1.0),
        "velocity_rms": float(np.sqrt(2.0 * e[sel_e, 0].mean() / mass)),
        "steps": steps,
        "wall_time_s": wall,
    }


def conservative_cases() -> dict:
    cases = {}
    for gradient in ("tanaka", "cmps"):
        sets = [f"fluid.pressure.gradient={gradient}", "fluid.boundary_force=momentum_exchange"]
        out = RESULTS_DIR / f"momentum_still_{gradient}.h5"
        cases[("still_water", 0, gradient)] = (
            out,
            [*sets, "run.end_time=0.5"],
            f"[still water {gradient}]",
        )
        out = RESULTS_DIR / f"momentum_dam_break_L40_{gradient}.h5"
        cases[("dam_break", 40, gradient)] = (
            out,
            [*sets, "fluid.spacing=0.00365", "run.end_time=0.4"],
            f"[dam break L/40 {gradient}]",
        )
    return cases


def window_sums(path: Path, t0: float, t1: float) -> dict:
    """Budget rows with t0 < time <= t1, summed; patch arrays (patches, dim)."""
    with h5py.File(path, "r") as h5:
        g = h5["momentum_budget"]
        t = g["time"][:]
        sel = (t > t0) & (t <= t1)
        out = {k: g[k][sel].sum(axis=0) for k in g if k not in ("time",)}
        out["patches"] = [str(p) for p in g.attrs["patches"]]
        out["model"] = str(g.attrs["boundary_force"])
    return out


def reported(b: dict, model: str) -> np.ndarray:
    """Per patch the impulse ``model`` reports (derived from the budget's parts where the run
    used another model: a fluid-only run's dynamics do not depend on it)."""
    if model == b["model"]:
        return b["patch_reported"]
    integral = b["patch_reported"]
    if b["model"] == "pressure_and_contact":
        integral = integral - b["patch_viscous"] - b["patch_collision"]
    if model == "pressure_integral":
        return integral
    return integral + b["patch_viscous"] + b["patch_collision"]


def residuals(b: dict, rep: np.ndarray) -> dict:
    explained_ext = b["gravity"] + b["sponge"] - rep.sum(axis=0)
    res_ext = b["momentum_change"] - explained_ext
    internal = b["internal_pressure"] + b["internal_viscous"] + b["internal_collision"]
    res = res_ext - internal
    scale = np.abs(rep).sum(axis=0)
    row = {}
    for a, ax in enumerate("xy"):
        row[f"momentum_change_{ax}"] = float(b["momentum_change"][a])
        row[f"boundary_impulse_{ax}"] = float(scale[a])
        row[f"internal_pressure_{ax}"] = float(b["internal_pressure"][a])
        row[f"residual_external_{ax}"] = float(res_ext[a])
        row[f"residual_external_rel_{ax}"] = float(res_ext[a] / scale[a]) if scale[a] else np.nan
        row[f"residual_{ax}"] = float(res[a])
    return row


def ringing(path: Path, probe: str, t0: float, t1: float) -> tuple[float, float]:
    """(peak |F_x|, RMS of the sample-to-sample jump of F_x / peak) of a force probe."""
    with h5py.File(path, "r") as h5:
        t = h5[f"probes/{probe}/time"][:]
        f = h5[f"probes/{probe}/value"][:, 0]
    sel = (t >= t0) & (t <= t1)
    peak = float(np.abs(f[sel]).max())
    return peak, float(np.sqrt(np.mean(np.diff(f[sel]) ** 2)) / peak)


def ringing_split(path: Path, probe: str, t0: float, t1: float, samples: int = 11) -> tuple:
    """The ringing of :func:`ringing` split into that of the load's own course (a cubic
    Savitzky-Golay fit over ``samples`` samples, 11 ms at 1 ms) and that of the residual about
    it, each as RMS of the sample-to-sample jump / peak |F_x| over [t0, t1]."""
    with h5py.File(path, "r") as h5:
        t = h5[f"probes/{probe}/time"][:]
        f = h5[f"probes/{probe}/value"][:, 0]
    fit = savgol_filter(f, samples, 3, mode="interp")
    sel = (t >= t0) & (t <= t1)
    peak = float(np.abs(f[sel]).max())

    def jump(g: np.ndarray) -> float:
        return float(np.sqrt(np.mean(np.diff(g[sel]) ** 2)) / peak)

    return jump(fit), jump(f - fit)


def obstacle_row(path: Path, n: int, model: str) -> dict:
    _, t0, t1 = WINDOWS["obstacle"][0]
    b = window_sums(path, t0, t1)
    rep = b["patch_reported"]
    member = [k for k, p in enumerate(b["patches"]) if p.startswith("obstacle")]
    with h5py.File(path, "r") as h5:
        tip = h5["probes/tip/value"][:, 0]
        tt = h5["probes/tip/time"][:]
        wall = float(h5.attrs.get("wall_time", np.nan))
    peak_inst, ring_inst = ringing(path, "force_last_step", t0, t1)
    peak_mean, ring_mean = ringing(path, "obstacle_force", t0, t1)
    return {
        "case": "obstacle",
        "resolution_L_over_l0": n,
        "force_model": model,
        "window": "impact",
        "t0_s": t0,
        "t1_s": t1,
        **residuals(b, rep),
        "member_impulse_x": float(rep[member, 0].sum()),
        "member_collision_impulse_x": float(b["patch_collision"][member, 0].sum()),
        "tip_peak_mm": float(1e3 * tip.max()),
        "tip_peak_time_s": float(tt[np.argmax(tip)]),
        "force_peak_last_step": peak_inst,
        "ringing_last_step": ring_inst,
        "force_peak_mean": peak_mean,
        "ringing_mean": ring_mean,
        "wall_time_s": wall,
    }


def dam_rows(path: Path, models: tuple[str, ...] = MODELS) -> list[dict]:
    rows = []
    for label, t0, t1 in WINDOWS["dam_break"]:
        b = window_sums(path, t0, t1)
        for model in models:
            rows.append(
                {
                    "case": "dam_break",
                    "resolution_L_over_l0": 40,
                    "force_model": model,
                    "window": label,
                    "t0_s": t0,
                    "t1_s": t1,
                    **residuals(b, reported(b, model)),
                }
            )
    return rows


def stability_row(path: Path, key: tuple) -> dict:
    case, n, gradient = key
    with h5py.File(path, "r") as h5:
        status = str(h5.attrs["status"])
        t = h5["momentum_budget/time"][:]
    return {
        "case": case,
        "resolution_L_over_l0": n,
        "force_model": f"momentum_exchange, gradient {gradient}",
        "window": "stability",
        "t0_s": 0.0,
        "t1_s": float(t[-1]) if len(t) else 0.0,
        "status": status.split(":")[0]
        + (": " + status.split(": ")[-1][:60] if ":" in status else ""),
    }


def _picked(cases: dict, only: list[str] | None) -> dict:
    """The cases whose results file name contains one of ``only`` (all without it)."""
    if not only:
        return cases
    return {k: v for k, v in cases.items() if any(o in v[0].name for o in only)}


#: the columns that name a row of the CSV
ROW_KEY = ("case", "resolution_L_over_l0", "force_model", "window")


def _merged(old: list[dict], new: list[dict]) -> list[dict]:
    """The CSV's rows with those of this run in place of the rows they repeat (same
    :data:`ROW_KEY`), and the new ones appended; values of old rows stay as written."""

    def key(r: dict) -> tuple[str, ...]:
        return tuple(str(r.get(k, "")) for k in ROW_KEY)

    fresh = {key(r): r for r in new}
    out = [fresh.pop(key(r), r) for r in old]
    return out + [r for r in new if key(r) in fresh]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    case_runner.add_run_options(ap)
    ap.add_argument(
        "--only",
        nargs="+",
        default=None,
        help="run and analyse only the cases whose results file name contains one of these "
        "strings (e.g. momentum_obstacle_L40_tanaka); the CSV keeps the other cases' rows",
    )
    args = ap.parse_args(argv)
    RESULTS_DIR.mkdir(parents=True, exist_ok=True)
    run = (args.threads, args.analyse_only, args.retry_failed)
    rows = []
    obstacle_scene = RESULTS_DIR / "dam_break_elastic_obstacle_2d_two_force_probes.toml"
    obstacle_scene.write_text(OBSTACLE.read_text() + INSTANT_PROBE)
    for key, path in case_runner.finished_cases(
        obstacle_scene, _picked(obstacle_cases(), args.only), *run
    ).items():
        rows.append(obstacle_row(path, key[1], key[2]))
    for path in case_runner.finished_cases(DAM, _picked(dam_cases(), args.only), *run).values():
        rows.extend(dam_rows(path))
        rows[-1].update(dam_quality(path))
    limited = _picked(limited_cases(), args.only)
    for key, (out, sets, tag) in limited.items():
        scene = {"still_water": STILL, "dam_break": DAM}.get(key[0], obstacle_scene)
        status = case_runner.case_status(scene, out, sets, *run, tag=tag)
        if status != "finished":
            if status is not None:
                rows.append(stability_row(out, key))
            continue
        model = VARIANTS[key[2]][1]
        if key[0] == "still_water":
            rows.append(still_row(out, model))
        elif key[0] == "dam_break":
            models = ("momentum_exchange",) if "tanaka" in key[2] else ("pressure_and_contact",)
            for row in dam_rows(out, models):
                rows.append(row | {"force_model": model})
            rows[-1].update(dam_quality(out))
        else:
            rows.append(obstacle_row(out, key[1], model))
    for key, (out, sets, tag) in _picked(conservative_cases(), args.only).items():
        scene = STILL if key[0] == "still_water" else DAM
        status = case_runner.case_status(scene, out, sets, *run, tag=tag)
        if status is not None:  # a blow-up is the result here
            rows.append(stability_row(out, key))
    if not rows:
        print("nothing to analyse")
        return 1
    table = rows  # the rows of this run are printed; with --only the CSV keeps the others
    if args.only:
        rows = _merged(read_csv(RESULTS_DIR / "momentum_budget.csv"), rows)
    columns = list(dict.fromkeys(k for r in rows for k in r))
    write_csv(
        rows,
        RESULTS_DIR / "momentum_budget.csv",
        columns,
        "momentum budget over impacts (validation/momentum_budget.py); impulses N s/m",
    )
    print("case        L/l0  model                 window    res_ext x (rel)   res_ext y (rel)")
    for r in table:
        if r["case"] == "still_water" and r["window"] != "stability":
            print(f"still water  {r['force_model']}: gauge {100 * r['gauge_mean_error_rel']:+.2f} %, "
                  f"velocity rms {r['velocity_rms']:.3f} m/s over 1-2 s")  # fmt: skip
            continue
        if r["window"] == "stability":
            print(f"{r['case']:10s} {r['resolution_L_over_l0']:>4}  {r['force_model']}: "
                  f"{r['status']} at t = {r['t1_s']:.3f} s")  # fmt: skip
            continue
        print(
            f"{r['case']:10s} {r['resolution_L_over_l0']:>4}  {r['force_model']:20s}  "
            f"{r['window']:8s}  {r['residual_external_x']:7.2f} ({100 * r['residual_external_rel_x']:5.1f} %)"
            f"  {r['residual_external_y']:7.2f} ({100 * r['residual_external_rel_y']:5.1f} %)"
            + (
                f"  member {r['member_impulse_x']:.2f} (collision {r['member_collision_impulse_x']:.2f})"
                f"  tip {r['tip_peak_mm']:.1f} mm at {r['tip_peak_time_s']:.3f} s"
                f"  ringing {r['ringing_last_step']:.3f} -> {r['ringing_mean']:.3f}"
                if r["case"] == "obstacle"
                else ""
            )
            + (
                f"  front {100 * r['rms_error_ko']:.1f} / {100 * r['rms_error_mm']:.1f} %"
                f" (shifted {100 * r['rms_error_shifted_ko']:.1f} / "
                f"{100 * r['rms_error_shifted_mm']:.1f} % by {r['offset_ms_ko']:.0f} / "
                f"{r['offset_ms_mm']:.0f} ms)  gauge noise {100 * r['gauge_noise_rel']:.0f} %"
                f"  {r['steps']} steps"
                if "gauge_noise_rel" in r
                else ""
            )
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
