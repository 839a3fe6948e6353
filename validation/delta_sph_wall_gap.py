"""A plate held above still water under δ-SPH: Adami's wall pressure against the "wetted" one.

Issue 21 / 20 (task H2). The thesis's bottom-slamming plate (A/H = 0.3, D/H = 0.06: the plate's
face D = 6.84 mm above the still water, l0 = H/20 = 5.7 mm, h = 1.3 l0) under δ-SPH: the first
fluid row is D + l0 = 12.5 mm from the plate's pressure layer, inside the kernel's support
2h = 14.8 mm, and Adami et al.'s extrapolation (2012, eq. 27) gives the plate's dummies a
negative pressure across that air gap (docs/validation_bottom_slamming_light.md, "Under the
δ-SPH fluid": -22.4 N/m of suction in the rigid plate's pressure integral over 0.5-1.0 s,
-3.4 N/m in its pair exchange, the light plate pulled down 3-4 mm). This script reruns the
same δ-SPH scenarios (validation/bottom_slamming_light_delta_sph.py's write_scenario and
overrides: the rigid plate with its pressure-integral and pair-exchange force probes, the heavy
elastic plate with Aitken, the light plate with M_f = 0.3 x the estimate and the force criterion
off) to ``--end-time`` (default 1.0 s: the wave reaches the plate at about 1.5 s) with
``fluid.sph.wall_pressure`` = each of ``--modes``, and reports over 0.5-1.0 s the plate's mean
and extreme load (N/m, up +) and, for the elastic plates, the mid-span displacement (mm).

    NUMBA_NUM_THREADS=1 python validation/delta_sph_wall_gap.py --modes wetted --runs rigid_x
    python validation/delta_sph_wall_gap.py --analyse-only

Writes validation/results/delta_sph_wall_gap.csv (one row per results file found).
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import h5py
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import case_runner  # noqa: E402
from bottom_slamming import (  # noqa: E402
    DEPTH,
    PLATE_FRONT,
    PLATE_LENGTH,
    RESULTS_DIR,
    spacing_for,
)
from bottom_slamming_light_delta_sph import CASE, L0, overrides, write_scenario  # noqa: E402
from results_csv import write_csv  # noqa: E402

CSV = RESULTS_DIR / "delta_sph_wall_gap.csv"
RUNS = ("rigid", "rigid_x", "heavy", "mf0.3")
MODES = ("adami", "wetted")
#: s: still water under the plate (the wave reaches it at about 1.5 s)
WINDOW = (0.5, 1.0)
#: m: a strip of the still water upstream of the plate, as long as the plate (the reference
#: level of the free surface for the one under the plate)
UPSTREAM = (PLATE_FRONT - 0.4, PLATE_FRONT - 0.4 + PLATE_LENGTH)


def surface_height(pos: np.ndarray, kind: np.ndarray, x0: float, x1: float, l0: float) -> float:
    """Mean over the lattice columns x0 < x < x1 of each column's highest fluid particle, m."""
    fl = (kind == 0) & (pos[:, 0] > x0) & (pos[:, 0] < x1)
    cols = np.round(pos[fl, 0] / l0).astype(np.int64)
    y = pos[fl, 1]
    return float(np.mean([y[cols == c].max() for c in np.unique(cols)]))


def surfaces(h5: h5py.File, l0: float) -> dict:
    """The free surface (top fluid row) under the plate and upstream at the snapshots nearest
    the ends of :data:`WINDOW`, m."""
    snaps = h5["particles"]
    times = {k: float(snaps[k].attrs.get("time", math.nan)) for k in snaps}
    out = {}
    for t in WINDOW:
        if not times:
            break
        k = min(times, key=lambda k: abs(times[k] - t))
        if abs(times[k] - t) > 0.05:
            continue
        g = snaps[k]
        pos, kind = g["position" if "position" in g else "pos"][:], g["kind"][:]
        under = surface_height(pos, kind, PLATE_FRONT, PLATE_FRONT + PLATE_LENGTH, l0)
        up = surface_height(pos, kind, *UPSTREAM, l0)
        out[f"surface_under_plate_mm_{t:g}s"] = 1e3 * under
        out[f"surface_upstream_mm_{t:g}s"] = 1e3 * up
    return out


def run_path(run: str, mode: str, end_time: float) -> Path:
    return RESULTS_DIR / f"dsph_wall_gap_{run}_{mode}_{L0}_end{end_time:g}_{CASE.label()}.h5"


def run_overrides(run: str, mode: str, spacing: float, end_time: float) -> list[str]:
    ft = "off" if run.startswith("mf") else "0.01"  # the light base runs without the criterion
    return overrides(run, spacing, end_time, ft) + [f'fluid.sph.wall_pressure="{mode}"']


def _series(h5: h5py.File, name: str, column: int) -> tuple[np.ndarray, np.ndarray]:
    g = h5["probes"][name]
    return g["time"][:], g["value"][:, column]


def analyse(path: Path, run: str, mode: str) -> dict:
    """Load and mid-span displacement over :data:`WINDOW`."""
    with h5py.File(path, "r") as h5:
        t, fy = _series(h5, "uplift", 1)
        row = {"run": run, "wall_pressure": mode, "results_file": path.name}
        row["t_end_s"] = float(t[-1]) if t.size else math.nan
        sel = (t > WINDOW[0]) & (t <= WINDOW[1])
        row["uplift_mean"] = float(fy[sel].mean()) if sel.any() else math.nan
        row["uplift_min"] = float(fy[sel].min()) if sel.any() else math.nan
        row["uplift_max"] = float(fy[sel].max()) if sel.any() else math.nan
        row["mid_disp_mean_mm"] = row["mid_disp_min_mm"] = math.nan
        row["mid_disp_min_time_s"] = math.nan
        if "plate_mid" in h5["probes"]:
            td, u = _series(h5, "plate_mid", 1)
            u = 1e3 * np.asarray(u)
            s2 = (td > WINDOW[0]) & (td <= WINDOW[1])
            if s2.any():
                row["mid_disp_mean_mm"] = float(u[s2].mean())
            upto = td <= WINDOW[1]
            if upto.any():
                k = int(np.argmin(u[upto]))
                row["mid_disp_min_mm"] = float(u[upto][k])
                row["mid_disp_min_time_s"] = float(td[upto][k])
        # past the still-water window (runs to the wave's arrival): the peak uplift and, for
        # the elastic plates, the largest upward mid-span displacement
        wet = t > WINDOW[1]
        row["peak_uplift"] = float(fy[wet].max()) if wet.any() else math.nan
        row["peak_time_s"] = float(t[wet][np.argmax(fy[wet])]) if wet.any() else math.nan
        row["mid_disp_max_mm"] = row["mid_disp_max_time_s"] = math.nan
        if "plate_mid" in h5["probes"] and wet.any():
            td, u = _series(h5, "plate_mid", 1)
            late = td > WINDOW[1]
            if late.any():
                k = int(np.argmax(u[late]))
                row["mid_disp_max_mm"] = 1e3 * float(u[late][k])
                row["mid_disp_max_time_s"] = float(td[late][k])
        if "coupling" in h5:
            c = h5["coupling"]
            row["it_per_window"] = float(np.mean(c["iterations"][:]))
            row["unconverged_windows"] = int(np.count_nonzero(c["converged"][:] == 0))
        row.update(surfaces(h5, spacing_for(float(L0), DEPTH)))
        row["wall_time_s"] = float(h5.attrs.get("wall_time", math.nan))
        row["steps"] = int(h5.attrs.get("steps", -1))
    return row


def report() -> int:
    rows = []
    for run in RUNS:
        for mode in MODES:
            pattern = run_path(run, mode, 0).name.replace("end0", "end*")
            for path, status in case_runner.readable_results(sorted(RESULTS_DIR.glob(pattern))):
                row = analyse(path, run, mode)
                row["status"] = status
                rows.append(row)
                print(
                    f"{run:8s} {mode:7s} to {row['t_end_s']:.3f} s: load over 0.5-1.0 s mean "
                    f"{row['uplift_mean']:+.3f} N/m (min {row['uplift_min']:+.3f}, max "
                    f"{row['uplift_max']:+.3f}); mid-span mean {row['mid_disp_mean_mm']:+.3f} mm, "
                    f"lowest {row['mid_disp_min_mm']:+.3f} mm at {row['mid_disp_min_time_s']:.3f} s; "
                    f"surface under the plate / upstream at 1 s "
                    f"{row.get('surface_under_plate_mm_1s', math.nan):.2f} / "
                    f"{row.get('surface_upstream_mm_1s', math.nan):.2f} mm; after 1 s peak "
                    f"{row['peak_uplift']:.2f} N/m at {row['peak_time_s']:.3f} s, mid-span max "
                    f"{row['mid_disp_max_mm']:.2f} mm at {row['mid_disp_max_time_s']:.3f} s"
                )
    if rows:
        write_csv(
            rows,
            CSV,
            list(dict.fromkeys(k for r in rows for k in r)),  # the rigid rows lack the coupling's
            comment="validation/delta_sph_wall_gap.py: the bottom-slamming plate (A/H = 0.3, "
            "D/H = 0.06, l0 = H/20) over still water under δ-SPH, fluid.sph.wall_pressure adami "
            "vs wetted; load = the uplift force probe (N/m, up +; rigid: pressure integral, "
            "rigid_x: pair exchange, elastic: the member's load), mid-span displacement mm "
            "(up +), means over 0.5-1.0 s; surface_*: mean height of the top fluid row under the "
            "plate and over an upstream strip as long, mm, at the snapshots at 0.5 and 1 s",
        )
        print(f"wrote {CSV}")
    return 0


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--runs", default="rigid_x", help=f"comma-separated of {', '.join(RUNS)}")
    ap.add_argument("--modes", default="wetted", help=f"comma-separated of {', '.join(MODES)}")
    ap.add_argument("--end-time", type=float, default=1.0, help="run.end_time, s (default 1.0)")
    case_runner.add_run_options(ap)
    args = ap.parse_args(argv)
    runs, modes = args.runs.split(","), args.modes.split(",")
    bad = [r for r in runs if r not in RUNS] + [m for m in modes if m not in MODES]
    if bad:
        ap.error(f"{bad}: runs must be among {RUNS}, modes among {MODES}")
    spacing = spacing_for(float(L0), DEPTH)
    if not args.analyse_only:
        for run in runs:
            kind = "rigid" if run.startswith("rigid") else "elastic"
            for mode in modes:
                case_runner.ensure_case(
                    write_scenario(kind),
                    run_path(run, mode, args.end_time),
                    run_overrides(run, mode, spacing, args.end_time),
                    args.threads,
                    args.retry_failed,
                    f"[wall gap {run} {mode}]",
                )
    return report()


if __name__ == "__main__":
    raise SystemExit(main())
