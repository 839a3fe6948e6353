"""Dam break far-wall gauges with the established MPS remedies for pressure noise (issue 20, part 3).

The set-up of validation/dam_break_wall_gauge.py (scenarios/dam_break_2d.toml to t = 0.4 s: the
surge reaches the far wall at t ~ 0.25 s, so about 0.15 s after the impact; 1 ms samples; its
noise metric, :func:`dam_break_wall_gauge.gauge_statistics`: RMS about an 11 ms Savitzky-Golay
fit from arrival + 20 ms to the end, relative to the fit's mean there) at its coarsest resolution
used for the Courant and compressibility rows, l0 = L/40, Courant 0.2, once per variant of
``[fluid.pressure]`` (:data:`VARIANTS`):

* ``thesis``: the default (mixed source term, thesis eq. 2-23; standard Laplacian, eq. 2-16);
* ``compressibility``: artificial compressibility kappa = 1e-6 1/Pa (sound speed 31.6 m/s);
* ``HS``: Khayyer & Gotoh (2009)'s higher-order source term (``source_term = "higher_order"``);
* ``HS+ECS``: with their error-compensating source term (2011; ``error_compensation = true``);
* ``HL``: their higher-order Laplacian (2010; ``laplacian = "higher_order"``);
* ``HS+ECS+HL``: all three.

A second gauge sits on the same wall 0.06 m above the floor (the study's gauge is at 0.02 m): the
runs use a copy of the scenario with that probe appended (results/pressure_remedies_dam_break.toml,
written by this script). Each case is an ``mpsfem run`` subprocess, resumable like every study in
validation/ (run them one at a time: ``--threads 1`` on a shared machine). Writes
validation/results/pressure_remedies.csv (per variant and gauge: arrival, peaks, mean after the
impact, noise in Pa and relative; the run's wall time) and prints
the table (docs/validation.md, "Pressure-noise remedies").

``--cost`` measures instead the cost of one step per variant (in this process, after a warm-up
that compiles every kernel): the dam break at l0 = L/90 (about 16k fluid particles), steps 20-80
from the start (the collapsing column), the variants in turn, each ``--repeats`` times, the
fastest repetition kept; writes validation/results/pressure_remedies_cost.csv (ms per step, its
assembly and solve parts, CG iterations per step).

    python validation/pressure_remedies.py [--threads 1] [--analyse-only] [--retry-failed]
    python validation/pressure_remedies.py --cost [--threads 1] [--repeats 3]
    python validation/pressure_remedies.py --fine [--threads 1]   (L/80, one run per variant)
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import h5py
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import case_runner  # noqa: E402 - validation/case_runner.py: resumable runs of one case
from dam_break import RESULTS_DIR, SCENARIO, L  # noqa: E402
from dam_break_wall_gauge import gauge_statistics  # noqa: E402
from dam_break_wall_gauge import overrides as gauge_overrides  # noqa: E402
from results_csv import write_csv  # noqa: E402

RESOLUTION = 40  # L / l0
COURANT = 0.2
KAPPA = 1e-6  # 1/Pa, the compressibility variant
#: gauges on the far wall (x = 4L = 0.584 m): probe name -> height above the floor (m)
GAUGES = {"right_wall_p": 0.02, "right_wall_p_high": 0.06}
EXTRA_PROBE = """
# added by validation/pressure_remedies.py: a second far-wall gauge, 0.06 m above the floor
[[probes]]
name = "right_wall_p_high"
kind = "pressure"
position = [0.584, 0.06]
radius = 0.0055
"""
#: variant name -> its [fluid.pressure] overrides
VARIANTS: dict[str, list[str]] = {
    "thesis": [],
    "compressibility": [f"fluid.pressure.compressibility={KAPPA!r}"],
    "HS": ["fluid.pressure.source_term=higher_order"],
    "HS+ECS": [
        "fluid.pressure.source_term=higher_order",
        "fluid.pressure.error_compensation=true",
    ],
    "HL": ["fluid.pressure.laplacian=higher_order"],
    "HS+ECS+HL": [
        "fluid.pressure.source_term=higher_order",
        "fluid.pressure.error_compensation=true",
        "fluid.pressure.laplacian=higher_order",
    ],
}
#: CG tolerances of the realisations of each variant, the default (1e-6) first: a tolerance
#: changes the pressures in their last digits and, through the free-surface flow, the particle
#: configuration within a few hundred steps, so the three runs show the metric's run-to-run
#: spread (the front study does the same, dam_break.py --sensitivity)
TOLERANCES = (1e-6, 5e-7, 2e-6)


def scenario_copy() -> Path:
    """The dam-break scenario with the second gauge appended (rewritten only when it changes)."""
    path = RESULTS_DIR / "pressure_remedies_dam_break.toml"
    text = SCENARIO.read_text() + EXTRA_PROBE
    if not path.is_file() or path.read_text() != text:
        path.write_text(text)
    return path


#: ``--fine``: variants run once (default tolerance) at l0 = L / FINE_RESOLUTION
FINE_RESOLUTION = 80
FINE_VARIANTS = ("thesis", "HS+ECS", "HL")


def case_path(name: str, tol: float = TOLERANCES[0], resolution: int = RESOLUTION) -> Path:
    tail = "" if tol == TOLERANCES[0] else f"_tol{tol:g}"
    return RESULTS_DIR / f"pressure_remedies_L{resolution}_{name.replace('+', '_')}{tail}.h5"


def case_overrides(
    name: str, tol: float = TOLERANCES[0], resolution: int = RESOLUTION
) -> list[str]:
    extra = [] if tol == TOLERANCES[0] else [f"fluid.pressure.tol={tol!r}"]
    return gauge_overrides(resolution, COURANT) + VARIANTS[name] + extra


def read_probe(path: Path, name: str) -> tuple[np.ndarray, np.ndarray]:
    """(t, p) of a pressure probe (s, Pa); a dry gauge (NaN) reads 0."""
    with h5py.File(path, "r") as h5:
        t = h5[f"probes/{name}/time"][:]
        p = h5[f"probes/{name}/value"][:]
    return t, np.nan_to_num(p, nan=0.0)


def wall_time(path: Path) -> float:
    """The run's wall time (s) as its results file records it."""
    with h5py.File(path, "r") as h5:
        return float(h5.attrs.get("wall_time", np.nan))


COST_RESOLUTION = 90  # L / l0 of the cost measurement
COST_STEPS = (20, 80)  # steps timed: from the first to the second (after the first's warm-up)


def step_cost(variant: str, threads: int) -> dict:
    """ms per step (and its assembly and solve parts, CG iterations per step) of one variant over
    the steps COST_STEPS of the dam break at l0 = L / COST_RESOLUTION."""
    import time

    import numba

    from mpsfem.fluid_mps.solver import FluidSolver
    from mpsfem.scenario.loader import load_scenario

    numba.set_num_threads(threads)
    over = [f"fluid.spacing={L / COST_RESOLUTION!r}", *VARIANTS[variant]]
    sc = load_scenario(SCENARIO, over).scenario
    solver = FluidSolver(sc.fluid)
    first, last = COST_STEPS
    for _ in range(first):
        solver.step(solver.dt_towards(1.0))
    tm = solver.times
    a0, s0, k0 = tm.assembly, tm.solve, len(tm.iterations)
    t0 = time.perf_counter()
    for _ in range(last - first):
        solver.step(solver.dt_towards(1.0))
    wall = time.perf_counter() - t0
    n = last - first
    return {
        "variant": variant,
        "fluid_particles": int(solver.n_fluid),
        "steps": n,
        "ms_per_step": round(1e3 * wall / n, 3),
        "assembly_ms_per_step": round(1e3 * (tm.assembly - a0) / n, 3),
        "solve_ms_per_step": round(1e3 * (tm.solve - s0) / n, 3),
        "cg_iterations_per_step": round(float(np.mean(tm.iterations[k0:])), 2),
    }


def cost_main(threads: int, repeats: int) -> int:
    names = list(VARIANTS)
    for name in names:  # warm-up: compile every kernel of every variant (cache or not)
        step_cost(name, threads)
    best: dict[str, dict] = {}
    for _ in range(repeats):
        for name in names:
            row = step_cost(name, threads)
            if name not in best or row["ms_per_step"] < best[name]["ms_per_step"]:
                best[name] = row
    rows = list(best.values())
    base = best["thesis"]["ms_per_step"]
    for r in rows:
        r["relative_to_thesis"] = round(r["ms_per_step"] / base, 3)
    comment = (
        "cost of one dam-break step per pressure variant (validation/pressure_remedies.py "
        f"--cost): l0 = L/{COST_RESOLUTION}, steps {COST_STEPS[0]}-{COST_STEPS[1]} from the start, "
        f"{threads} numba thread(s), fastest of {repeats} interleaved repetitions on a shared "
        "machine"
    )
    write_csv(rows, RESULTS_DIR / "pressure_remedies_cost.csv", comment=comment)
    print("variant           particles  ms/step  assembly  solve  CG its  vs thesis")
    for r in rows:
        print(
            f"{r['variant']:<16}  {r['fluid_particles']:9d}  {r['ms_per_step']:7.2f}  "
            f"{r['assembly_ms_per_step']:8.2f}  {r['solve_ms_per_step']:5.2f}  "
            f"{r['cg_iterations_per_step']:6.1f}  {r['relative_to_thesis']:9.3f}"
        )
    return 0


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    case_runner.add_run_options(ap)
    ap.add_argument("--only", nargs="*", default=None, help="variants to run (default: all)")
    ap.add_argument("--cost", action="store_true", help="measure the cost of one step instead")
    ap.add_argument("--repeats", type=int, default=3, help="--cost: repetitions per variant")
    ap.add_argument(
        "--fine",
        action="store_true",
        help=f"run {', '.join(FINE_VARIANTS)} once at L/{FINE_RESOLUTION} instead",
    )
    args = ap.parse_args(argv)
    if args.cost:
        return cost_main(args.threads, args.repeats)
    RESULTS_DIR.mkdir(parents=True, exist_ok=True)
    scenario = scenario_copy()
    resolution = FINE_RESOLUTION if args.fine else RESOLUTION
    tols = TOLERANCES[:1] if args.fine else TOLERANCES
    names = list(FINE_VARIANTS) if args.fine else list(VARIANTS)
    if args.only:
        names = [n for n in names if n in args.only]
    cases = {
        (n, tol): (
            case_path(n, tol, resolution),
            case_overrides(n, tol, resolution),
            f"[{n}, CG tol {tol:g}, L/{resolution}]",
        )
        for tol in tols
        for n in names
    }
    paths = case_runner.finished_cases(
        scenario, cases, args.threads, args.analyse_only, args.retry_failed
    )
    if not paths:
        print("nothing to analyse")
        return 1
    rows = []
    for (name, tol), path in paths.items():
        wall = wall_time(path)
        for gauge, height in GAUGES.items():
            stats = gauge_statistics(*read_probe(path, gauge))
            rows.append(
                {"variant": name, "cg_tol": tol, "gauge": gauge, "gauge_height_m": height}
                | {k: round(v, 6) if isinstance(v, float) else v for k, v in vars(stats).items()}
                | {"wall_time_s": round(wall, 1)}
            )
    comment = (
        "dam break far-wall gauges with the MPS pressure-noise remedies "
        f"(validation/pressure_remedies.py): l0 = L/{resolution} = {L / resolution:.5f} m, Courant "
        f"{COURANT}, to t = 0.4 s; per variant and gauge the arrival, impact peak, smoothed peak, "
        "mean of the smoothed signal after the impact, noise = RMS of raw - smoothed (11 ms "
        "Savitzky-Golay) from arrival + 20 ms, in Pa and relative to that mean; run wall time (s, "
        "one numba thread on a shared machine)"
    )
    name = "pressure_remedies_L80.csv" if args.fine else "pressure_remedies.csv"
    write_csv(rows, RESULTS_DIR / name, comment=comment)
    print(
        "variant          CG tol  gauge (m)  arrival  peak (Pa)  mean after  noise rms"
        "           wall"
    )
    for r in sorted(rows, key=lambda r: (list(VARIANTS).index(r["variant"]), r["gauge"])):
        print(
            f"{r['variant']:<15}  {r['cg_tol']:6.0e}  {r['gauge_height_m']:9.2f}  "
            f"{r['arrival_s']:.3f} s  "
            f"{r['peak_pa']:8.0f}  {r['mean_after_impact_pa']:9.0f}  "
            f"{r['noise_rms_pa']:5.0f} Pa ({100 * r['noise_relative']:5.1f} %)  "
            f"{r['wall_time_s']:6.0f} s"
        )
    return 0 if len(paths) == len(cases) else 1


if __name__ == "__main__":
    sys.exit(main())
