"""Work-precision of MPS and δ-SPH on the dam break and on the coupled hydrostatic plate (issue 23).

Cases: {mps, delta-sph} x {dam break, coupled plate} x 3 resolutions x numba threads {1, 2}, each
an ``mpsfem run`` subprocess (validation/case_runner.py: resumable, one results file per case
under validation/results/work_precision/).

* dam break: scenarios/dam_break_2d.toml (MPS) and validation/delta_sph_dam_break.py's δ-SPH
  scenario (same geometry, Koshizuka & Oka 1996), l0 = L/10, L/20, L/40, run to the end of the
  front metric's window (the last Koshizuka & Oka point with T <= 3 plus one probe interval,
  0.24 s). Error: validation/dam_break.py's RMS relative error in Z = x/L over 0.5 <= T <= 3
  against Koshizuka & Oka, raw and after the best gate lag of the experiment <= 30 ms
  (validation/delta_sph_dam_break.py's ``bounded_shift``).
* coupled plate: scenarios/hydrostatic_plate_2d.toml (validation/delta_sph_hydrostatic_plate.py:
  water 2 m deep on a clamped aluminium plate strip, implicit IQN-ILS coupling), l0 = 1/20,
  1/30, 1/40 m, 0.2 s, mean of the mid deflection for t >= 0.05 s. Error: |mean / w_beam - 1|
  with the clamped-beam deflection w_beam = 6.86e-5 m.

Cost: wall time per simulated second (the results file's ``wall_time``, from opening the file to
the end, JIT loading included), with the fluid solver's own stage times (``stage_times``: the
rest is set-up, output and, for the plate, the structure and the coupler), the subprocess's wall
and CPU time (user + system, Python start-up included), the steps and the particles (fluid +
wall). The 1-minute load average at the start and end of every run is recorded: the timings
mean something only on a quiet machine, and a one-thread run's CPU time / wall time below one
says it shared its core. A warm-up (a few steps of each method on each case, untimed) fills
numba's on-disk cache first, so no timed run compiles. Each error carries its noise (dam break:
the spread of MPS realisations at L/40; plate: batch means), and "which method wins where" is
read off the cost-error front with that noise as a tie (:func:`who_wins`).

The whole default study (24 runs) is sized for at most 15 minutes on a quiet 2-core machine;
the script prints its estimate (:data:`EXPECTED_S`) before it starts.

Writes validation/results/work_precision.csv, docs/figures/work_precision.png and
docs/validation_work_precision.md (generated from the CSV; ``--report-only`` regenerates the
figure and page from the CSV alone). ``--reduced`` runs a smaller grid (the pipeline check).

    python validation/work_precision.py [--threads 1 2] [--only mps plate ...] [--reduced]
        [--analyse-only | --report-only] [--retry-failed] [--fresh]

Finished runs are skipped (resumable): for timings of one quiet machine state, start with
``--fresh``, which deletes the selected runs' results files first.
"""

from __future__ import annotations

import argparse
import ast
import math
import os
import resource
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import h5py
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import case_runner  # noqa: E402 - resumable subprocess runs
import dam_break  # noqa: E402 - the MPS study: reference curves, front metric
import delta_sph_dam_break  # noqa: E402 - δ-SPH dam-break scenario, the <= 30 ms gate lag
import delta_sph_hydrostatic_plate as plate_study  # noqa: E402 - plate scene, beam theory
from results_csv import read_csv, write_csv  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
RUNS = ROOT / "validation" / "results" / "work_precision"
CSV = ROOT / "validation" / "results" / "work_precision.csv"
FIGURE = ROOT / "docs" / "figures" / "work_precision.png"
PAGE = ROOT / "docs" / "validation_work_precision.md"

METHODS = ("mps", "delta-sph")
CASES = ("dam_break", "plate")
LEVELS = ("coarse", "medium", "fine")
#: per configuration and case, the resolutions of LEVELS: L / l0 (dam break), l0 in m (plate)
RESOLUTIONS = {
    "full": {"dam_break": (10, 20, 40), "plate": (1 / 20, 1 / 30, 1 / 40)},
    "reduced": {"dam_break": (8, 10, 14), "plate": (1 / 20, 1 / 24, 1 / 30)},
}
# s: the plate study's start-up transient (validation/delta_sph_hydrostatic_plate.py)
PLATE_SETTLE = 0.05
PLATE_END = {"full": 0.2, "reduced": 0.1}  # s; full = the plate study's run
PLATE_BATCHES = 5  # batch means for the plate mean's standard error
SENSITIVITY_CSV = ROOT / "docs" / "figures" / "dam_break_front_sensitivity.csv"
PROBE_INTERVAL = 0.002  # s: the dam-break scenarios' probe interval
#: 1-thread seconds per run of the full grid, Python start-up included: the CPU seconds (user +
#: system) of the one-thread full-grid runs on the project's 2-core machine (2026-11-26, made on
#: a loaded machine, where CPU time still counts only the run's own work: MPS dam break 2.4 /
#: 3.9 / 13.8 s, δ-SPH 2.3 / 5.3 / 22.8 s, plate MPS 20.3 / 23.2 / 27.9 s, δ-SPH 16.7 / 22.4 /
#: 27.5 s) times 1.3; 2 threads: the same (a bound)
EXPECTED_S = {
    ("mps", "dam_break"): (4.0, 6.0, 18.0),
    ("delta-sph", "dam_break"): (4.0, 7.0, 30.0),
    ("mps", "plate"): (27.0, 31.0, 37.0),
    ("delta-sph", "plate"): (22.0, 30.0, 36.0),
}
WARMUP_S = 60.0  # the warm-up runs with numba's cache filled; the first ever adds compilation


def dam_break_end_time() -> float:
    """End time (s) that covers the front metric: the last Koshizuka & Oka point with
    T <= 3 plus one probe interval, rounded up to 5 ms (0.24 s)."""
    ref = dam_break.references()["Koshizuka & Oka 1996"]
    t_last = ref[ref[:, 0] <= dam_break.T_RANGE[1], 0].max() / dam_break.T_SCALE
    return math.ceil((t_last + PROBE_INTERVAL) / 0.005) * 0.005


@dataclass(frozen=True)
class Case:
    """One run of the study."""

    method: str
    case: str
    level: str
    resolution: float  # L / l0 (dam break) or l0 in m (plate)
    threads: int
    config: str

    @property
    def spacing(self) -> float:
        """l0, m."""
        return dam_break.L / self.resolution if self.case == "dam_break" else self.resolution

    @property
    def end_time(self) -> float:
        return dam_break_end_time() if self.case == "dam_break" else PLATE_END[self.config]

    @property
    def scenario(self) -> Path:
        if self.case == "plate":
            return plate_study.SCENE
        return delta_sph_dam_break.SCENARIO if self.method == "delta-sph" else dam_break.SCENARIO

    @property
    def label(self) -> str:
        res = f"L{self.resolution:g}" if self.case == "dam_break" else f"l0_{self.resolution:.4g}"
        return f"{self.config}_{self.method}_{self.case}_{res}_t{self.end_time:g}_{self.threads}thr"

    @property
    def path(self) -> Path:
        return RUNS / f"{self.label}.h5"

    def overrides(self) -> list[str]:
        over = [
            f"fluid.spacing={self.spacing!r}",
            f"run.end_time={self.end_time!r}",
            f"output.checkpoint_interval={self.end_time / 2!r}",
        ]
        if self.case == "dam_break":  # one snapshot at the start: the particle count
            return over + [f"output.snapshot_interval={self.end_time!r}"]
        return over + [f'fluid.method="{self.method}"', "output.snapshot_interval=0"]


def all_cases(config: str, threads: tuple[int, ...], only: tuple[str, ...]) -> list[Case]:
    """The study's runs in the order they run (cheap first), filtered by ``only``: a run is
    kept when, for each of method / case / level / thread count named in ``only``, its own is
    among those named (``--only mps plate`` = MPS on the plate; ``--only fine 2`` = the finest
    runs on two threads)."""
    groups = {"method": set(METHODS), "case": set(CASES), "level": set(LEVELS)}
    chosen: dict[str, set[str]] = {}
    for token in only:
        kind = next((k for k, v in groups.items() if token in v), None)
        if kind is None and token.isdigit():
            kind = "threads"
        if kind is None:
            allowed = ", ".join(sorted(set().union(*groups.values())))
            raise SystemExit(f"--only {token!r}: not one of {allowed} or a thread count")
        chosen.setdefault(kind, set()).add(token)
    cases = []
    for level_i, level in enumerate(LEVELS):
        for case in CASES:
            for method in METHODS:
                for n in threads:
                    c = Case(method, case, level, RESOLUTIONS[config][case][level_i], n, config)
                    values = {"method": method, "case": case, "level": level, "threads": str(n)}
                    if all(values[k] in v for k, v in chosen.items()):
                        cases.append(c)
    return cases


def estimate_seconds(cases: list[Case]) -> float:
    """Expected wall seconds of ``cases`` on a quiet 2-core machine from :data:`EXPECTED_S`.
    A reduced-grid run: the dam break scaled from the full grid's coarsest by (l0 ratio)^3
    (particles x steps), at least the 5 s start-up; the plate by its end time (its cost is
    mostly per coupling window)."""
    total = 0.0
    for c in cases:
        base = EXPECTED_S[(c.method, c.case)]
        if c.config == "full":
            total += base[LEVELS.index(c.level)]
        elif c.case == "dam_break":
            ratio = c.resolution / RESOLUTIONS["full"]["dam_break"][0]
            total += max(5.0, base[0] * ratio**3)
        else:
            total += base[LEVELS.index(c.level)] * c.end_time / PLATE_END["full"]
    return total


# --------------------------------------------------------------------------- error metrics


def dam_break_errors(T: np.ndarray, Z: np.ndarray, reference: np.ndarray) -> dict[str, float]:
    """The front metric of a curve Z(T) (Z = x/L, T = t sqrt(2g/L)) against one experiment:
    raw RMS relative error over 0.5 <= T <= 3 (dam_break.front_error), the best gate lag of the
    experiment in [0, 30 ms] and the error after it (delta_sph_dam_break.bounded_shift)."""
    shift, shifted = delta_sph_dam_break.bounded_shift(T, Z, reference)
    return {
        "error_raw": dam_break.front_error(T, Z, reference),
        "lag_ms": 1e3 * shift / dam_break.T_SCALE,
        "error_shifted": shifted,
    }


def plate_error(t: np.ndarray, w: np.ndarray, settle: float = PLATE_SETTLE) -> dict[str, float]:
    """Mean mid deflection w (m, y component; negative = down) over t >= settle against the
    clamped-beam value: mean, std and |mean / -w_beam - 1| (w_beam = 6.86e-5 m,
    validation/delta_sph_hydrostatic_plate.py), and the mean's noise relative to w_beam: twice
    the standard error from :data:`PLATE_BATCHES` batch means (the oscillation is correlated
    in time, so not std / sqrt(samples))."""
    keep = t >= settle - 1e-12
    mean = float(w[keep].mean())
    batches = [b.mean() for b in np.array_split(w[keep], PLATE_BATCHES)]
    standard_error = float(np.std(batches, ddof=1) / np.sqrt(PLATE_BATCHES))  # batch means
    return {
        "mean_w_mid_m": mean,
        "std_w_mid_m": float(w[keep].std()),
        "error": abs(-mean / plate_study.W_STATIC - 1.0),
        "error_noise": 2.0 * standard_error / plate_study.W_STATIC,
    }


def dam_break_noise(path: Path = SENSITIVITY_CSV) -> float:
    """The spread (max - min) of the shifted front error against Koshizuka & Oka over MPS's
    L/40 realisations that differ only in the CG tolerance (validation/dam_break.py
    --sensitivity): the metric's own noise; 0 without that file."""
    if not path.is_file():
        return 0.0
    values = [
        float(r["rms_error_shifted_ko"])
        for r in read_csv(path)
        if (r["variant"] == "defaults" or r["variant"].startswith("cg_tol"))
        and r["rms_error_shifted_ko"]
    ]
    return max(values) - min(values) if len(values) > 1 else 0.0


# --------------------------------------------------------------------------- running


TIMING_KEYS = ("wp_process_wall_s", "wp_cpu_s", "wp_attempts")


def children_cpu() -> float:
    """User + system CPU seconds of this process's finished children."""
    ru = resource.getrusage(resource.RUSAGE_CHILDREN)
    return ru.ru_utime + ru.ru_stime


def record_attempt(path: Path, wall: float, cpu: float, load_start: float, load_end: float):
    """Add one attempt's process wall and CPU time to the results file's attributes (a resumed
    run adds up), with the load average before its first and after its last attempt."""
    if case_runner.read_status(path) in (None, "locked") or not path.is_file():
        return
    with h5py.File(path, "r+") as h5:
        first = "wp_attempts" not in h5.attrs
        h5.attrs["wp_process_wall_s"] = float(h5.attrs.get("wp_process_wall_s", 0.0)) + wall
        h5.attrs["wp_cpu_s"] = float(h5.attrs.get("wp_cpu_s", 0.0)) + cpu
        h5.attrs["wp_attempts"] = int(h5.attrs.get("wp_attempts", 0)) + 1
        if first:
            h5.attrs["wp_load_start"] = load_start
        h5.attrs["wp_load_end"] = load_end
        h5.attrs["wp_cpu_count"] = os.cpu_count() or 0


def delete_results(cases: list[Case]) -> None:
    """Delete the results file, checkpoint and sidecar of each case (``--fresh``)."""
    for c in cases:
        for f in RUNS.glob(f"{c.label}.*"):
            f.unlink()


def run_case(case: Case, retry: bool) -> str:
    """Run (or resume, or skip) one case with its timing recorded; its status."""
    status = case_runner.read_status(case.path)
    if status == "finished":
        print(f"{case.label}: finished, skipped")
        return status
    load_start = os.getloadavg()[0]
    cpu0, t0 = children_cpu(), time.perf_counter()
    status = case_runner.ensure_case(
        case.scenario, case.path, case.overrides(), case.threads, retry, f"[{case.label}]"
    )
    wall, cpu = time.perf_counter() - t0, children_cpu() - cpu0
    load_end = os.getloadavg()[0]
    if wall > 0.5:  # a run happened (a failed case not retried returns at once)
        record_attempt(case.path, wall, cpu, load_start, load_end)
        print(f"  {status}: {wall:.1f} s wall, {cpu:.1f} s CPU, load {load_start:.2f} -> "
              f"{load_end:.2f}", flush=True)  # fmt: skip
    return status


def warm_up(cases: list[Case]) -> None:
    """A few steps of each (method, case) that will run, untimed, coarsest spacing: fills
    numba's on-disk cache so that no timed run compiles."""
    done = set()
    RUNS.mkdir(parents=True, exist_ok=True)
    for c in cases:
        if (c.method, c.case) in done or case_runner.read_status(c.path) == "finished":
            continue
        done.add((c.method, c.case))
        out = RUNS / f"warmup_{c.method}_{c.case}.h5"
        out.unlink(missing_ok=True)
        coarsest = RESOLUTIONS[c.config][c.case][0]
        warm = Case(c.method, c.case, "coarse", coarsest, c.threads, c.config)
        over = [o for o in warm.overrides() if not o.startswith(("run.end_time", "output."))]
        over += ["run.end_time=0.004", "output.snapshot_interval=0"]
        over += ["output.checkpoint_interval=0.004"]
        t0 = time.perf_counter()
        case_runner.run_scenario(warm.scenario, out, over, 1, tag="[warm-up]")
        print(f"  warm-up {c.method} {c.case}: {time.perf_counter() - t0:.1f} s", flush=True)
        out.unlink(missing_ok=True)
        for extra in out.parent.glob(out.stem + "*"):
            extra.unlink()


# --------------------------------------------------------------------------- analysis


def analyse_case(case: Case) -> dict:
    """One CSV row: the case, its cost and its error (blank where it did not finish)."""
    row: dict = {
        "config": case.config,
        "case": case.case,
        "method": case.method,
        "level": case.level,
        "resolution": f"L/{case.resolution:g}"
        if case.case == "dam_break"
        else f"{case.resolution:.3g} m",
        "spacing_m": case.spacing,
        "threads": case.threads,
        "t_end_s": case.end_time,
        "run": case.path.name,
    }
    status = case_runner.read_status(case.path)
    row["status"] = status or "missing"
    if status != "finished":
        return row
    with h5py.File(case.path, "r") as h5:
        attrs = dict(h5.attrs)
        if case.case == "dam_break":
            snap = h5["particles"][sorted(h5["particles"])[0]]
            particles = int(snap["kind"].shape[0])
            fluid = int(np.count_nonzero(snap["kind"][()] == 0))
        else:
            particles, fluid = int(attrs["particles"]), None
            tw = h5["probes/mid_deflection/time"][()]
            w = h5["probes/mid_deflection/value"][()][:, 1]
            iterations = h5["coupling/iterations"][()]
    wall = float(attrs["wall_time"])
    stages = ast.literal_eval(str(attrs.get("stage_times", "{}")))
    row["fluid_stages_s"] = sum(v for k, v in stages.items() if not k.endswith("_calls"))
    row.update(
        particles=particles,
        fluid_particles=fluid if fluid is not None else "",
        steps=int(attrs["steps"]),
        run_wall_s=wall,
        wall_per_sim_s=wall / case.end_time,
        process_wall_s=float(attrs.get("wp_process_wall_s", np.nan)),
        cpu_s=float(attrs.get("wp_cpu_s", np.nan)),
        attempts=int(attrs.get("wp_attempts", 0)),
        load_start=float(attrs.get("wp_load_start", np.nan)),
        load_end=float(attrs.get("wp_load_end", np.nan)),
        cpu_count=int(attrs.get("wp_cpu_count", os.cpu_count() or 0)),
    )
    row["cpu_per_wall_thread"] = row["cpu_s"] / (row["process_wall_s"] * case.threads)
    if case.case == "dam_break":
        T, Z = dam_break.front_curve(case.path)
        row["metric_T_max"] = float(T[-1])
        ko = dam_break.references()["Koshizuka & Oka 1996"]
        needed = ko[(ko[:, 0] >= dam_break.T_RANGE[0]) & (ko[:, 0] <= dam_break.T_RANGE[1]), 0]
        if T[-1] < needed.max():
            row["status"] = f"front curve ends at T = {T[-1]:.3f} < {needed.max():.3f}"
            return row
        e = dam_break_errors(T, Z, ko)
        row.update(error=e["error_shifted"], error_raw=e["error_raw"], lag_ms=e["lag_ms"])
        row["error_noise"] = dam_break_noise()
    else:
        e = plate_error(tw, w)
        row.update(e)
        row["coupling_iterations_mean"] = float(iterations.mean())
    return row


COLUMNS = (
    "config", "case", "method", "level", "resolution", "spacing_m", "threads", "t_end_s",
    "status", "particles", "fluid_particles", "steps", "error", "error_noise", "error_raw", "lag_ms",
    "mean_w_mid_m", "std_w_mid_m", "coupling_iterations_mean", "run_wall_s", "fluid_stages_s",
    "wall_per_sim_s",
    "process_wall_s", "cpu_s", "cpu_per_wall_thread", "attempts", "load_start", "load_end",
    "cpu_count", "metric_T_max", "run",
)  # fmt: skip
CSV_COMMENT = (
    "work-precision, MPS vs delta-SPH (validation/work_precision.py): error = dam break: RMS "
    "relative front error vs Koshizuka & Oka over 0.5 <= T <= 3 after the best gate lag <= 30 "
    "ms (error_raw: unshifted); plate: |mean mid deflection (t >= 0.05 s) / 6.86e-5 m - 1|; "
    "cost = run_wall_s / t_end_s (wall_per_sim_s); load = 1-minute load average"
)


# --------------------------------------------------------------------------- report


def _num(row: dict, key: str) -> float:
    try:
        return float(row.get(key, "") or "nan")
    except ValueError:
        return float("nan")


def finished_rows(rows: list[dict]) -> list[dict]:
    """The rows with an error and a cost."""
    return [
        r
        for r in rows
        if r.get("status") == "finished"
        and np.isfinite(_num(r, "error"))
        and np.isfinite(_num(r, "wall_per_sim_s"))
    ]


def pareto_front(rows: list[dict], tie: float = 0.0) -> list[dict]:
    """The best trade-offs of ``rows``, cheapest first: walking up in cost, a run is kept when
    its error is below the last kept run's by more than ``tie`` (the error's noise; with 0,
    the Pareto front of cost and error)."""
    front: list[dict] = []
    for r in sorted(rows, key=lambda r: (_num(r, "wall_per_sim_s"), _num(r, "error"))):
        if not front or _num(r, "error") < _num(front[-1], "error") - tie:
            front.append(r)
    return front


def noise(rows: list[dict]) -> float:
    """The largest ``error_noise`` of ``rows`` (0 when none is recorded): the error difference
    below which two runs tie."""
    values = [_num(r, "error_noise") for r in rows]
    return max([v for v in values if np.isfinite(v)], default=0.0)


METHOD_NAMES = {"mps": "MPS", "delta-sph": "δ-SPH"}
ARTICLE = {"MPS": "an", "δ-SPH": "a"}
CASE_NAMES = {"dam_break": "dam break", "plate": "coupled hydrostatic plate"}


def _g(x: float) -> str:
    return f"{x:.0f}" if abs(x) >= 100 else f"{x:.3g}"


def who_wins(rows: list[dict]) -> str:
    """One sentence from :func:`pareto_front` of ``rows`` (one case, one thread count) with
    the rows' :func:`noise` as the tie: which method gives which error at the least cost."""
    rows = finished_rows(rows)
    if not rows:
        return "no finished runs."
    tie = noise(rows)
    front = pareto_front(rows, tie)
    methods = {r["method"] for r in rows}
    winners = {r["method"] for r in front}
    tie_text = (
        f" (errors within {100 * tie:.2g} percentage points of each other count as a tie)"
        if tie
        else ""
    )
    errors = [_num(r, "error") for r in rows]
    if len(methods) > 1 and max(errors) - min(errors) <= tie:
        cheapest = front[0]
        return (
            f"every error lies within the noise ({100 * min(errors):.2g}-"
            f"{100 * max(errors):.2g} %, noise {100 * tie:.2g} percentage points): accuracy does "
            f"not separate the methods here, and the cheapest run is "
            f"{METHOD_NAMES[cheapest['method']]} {cheapest['resolution']} at "
            f"{_g(_num(cheapest, 'wall_per_sim_s'))} s/s."
        )
    if len(winners) == 1:
        m = METHOD_NAMES[front[0]["method"]]
        if len(methods) == 1:
            return f"only {m} finished."
        other = METHOD_NAMES[next(iter(methods - winners))]
        return (
            f"{m} wins over the whole measured range: for every {other} run {ARTICLE[m]} {m} run "
            f"costs less and is no less accurate{tie_text}; {m}'s best trade-offs: "
            + "; ".join(
                f"{r['resolution']} ({100 * _num(r, 'error'):.2g} % at "
                f"{_g(_num(r, 'wall_per_sim_s'))} s/s)"
                for r in front
            )
            + "."
        )
    segments: list[tuple[str, list[dict]]] = []  # runs of one method along the front
    for r in front:
        if segments and segments[-1][0] == r["method"]:
            segments[-1][1].append(r)
        else:
            segments.append((r["method"], [r]))
    parts = []
    for method, seg in segments:
        lo, hi = _num(seg[0], "wall_per_sim_s"), _num(seg[-1], "wall_per_sim_s")
        e_hi, e_lo = _num(seg[0], "error"), _num(seg[-1], "error")
        cost = f"{_g(lo)} s/s" if lo == hi else f"{_g(lo)}-{_g(hi)} s/s"
        err = f"{100 * e_lo:.2g} %" if e_lo == e_hi else f"{100 * e_hi:.2g}-{100 * e_lo:.2g} %"
        res = ", ".join(r["resolution"] for r in seg)
        parts.append(f"{METHOD_NAMES[method]} ({res}) at {cost}, error {err}")
    return f"cheapest first, the best trade-offs{tie_text} are " + "; then ".join(parts) + "."


def _conditions(rows: list[dict]) -> tuple[list[float], list[float], int]:
    """The finished runs' 1-minute load averages (start and end), the one-thread runs' CPU
    time / wall time (a two-thread run's is below one on a quiet machine too: its serial
    parts), and the core count."""
    done = finished_rows(rows)
    loads = [_num(r, k) for r in done for k in ("load_start", "load_end")]
    use = [_num(r, "cpu_per_wall_thread") for r in done if int(_num(r, "threads")) == 1]
    cores = [int(_num(r, "cpu_count")) for r in done if np.isfinite(_num(r, "cpu_count"))]
    return (
        [x for x in loads if np.isfinite(x)],
        [x for x in use if np.isfinite(x)],
        max(cores, default=0),
    )


def is_loaded(rows: list[dict]) -> bool:
    """Whether any finished run saw a 1-minute load above the core count, or a one-thread run
    got less than 80 % of a core."""
    loads, use, cores = _conditions(rows)
    return any(x > cores for x in loads) or any(x < 0.8 for x in use)


def machine_note(rows: list[dict]) -> str:
    """What the recorded load averages and CPU use say about the timings."""
    loads, use, cores = _conditions(rows)
    if not loads:
        return "No load averages were recorded; the timings' conditions are unknown."
    text = f"The 1-minute load average ranged {min(loads):.2f}-{max(loads):.2f} over the runs ({cores} cores)"
    if use:
        text += f"; the one-thread runs' CPU time / wall time ranged {min(use):.2f}-{max(use):.2f}"
    text += ". "
    if is_loaded(rows):
        return text + (
            "**These timings come from a loaded machine** (a load above the core count, or "
            "one-thread runs that got less than 80 % of a core): other jobs shared the cores, "
            "the costs are inflated unevenly and the two-thread runs suffer most. Re-run on a "
            "quiet machine before drawing conclusions about cost."
        )
    return text + "The machine was quiet enough for the timings to compare."


def figure(rows: list[dict], path: Path = FIGURE) -> None:
    """Two log-log panels (dam break, plate): wall seconds per simulated second against error;
    marker = method, line style = thread count."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.ticker import FormatStrFormatter, LogLocator

    markers = {"mps": "o", "delta-sph": "s"}
    colours = {"mps": "C0", "delta-sph": "C3"}
    styles = {1: "-", 2: "--"}
    fig, axes = plt.subplots(1, 2, figsize=(10.0, 4.2))
    done = finished_rows(rows)
    for ax, case in zip(axes, CASES, strict=True):
        for method in METHODS:
            for threads in sorted({int(_num(r, "threads")) for r in done}):
                pts = sorted(
                    (
                        r
                        for r in done
                        if r["case"] == case
                        and r["method"] == method
                        and int(_num(r, "threads")) == threads
                    ),
                    key=lambda r: _num(r, "spacing_m"),
                    reverse=True,
                )
                if not pts:
                    continue
                x = [100 * _num(r, "error") for r in pts]
                y = [_num(r, "wall_per_sim_s") for r in pts]
                ax.plot(
                    x,
                    y,
                    styles.get(threads, ":"),
                    marker=markers[method],
                    color=colours[method],
                    mfc=colours[method] if threads == 1 else "none",
                    label=f"{METHOD_NAMES[method]}, {threads} thread{'s' if threads > 1 else ''}",
                )
                if threads == min(int(_num(r, "threads")) for r in done):
                    for r, xi, yi in zip(pts, x, y, strict=True):
                        ax.annotate(r["resolution"], (xi, yi), fontsize=7, xytext=(3, 3),
                                    textcoords="offset points")  # fmt: skip
        ax.set_xscale("log")
        ax.set_yscale("log")
        for axis in (ax.xaxis, ax.yaxis):
            axis.set_minor_locator(LogLocator(subs=(2.0, 3.0, 5.0)))
            axis.set_major_formatter(FormatStrFormatter("%g"))
            axis.set_minor_formatter(FormatStrFormatter("%g"))
        ax.tick_params(which="minor", labelsize=7)
        ax.set_xlabel(
            "RMS front error vs Koshizuka & Oka after a lag <= 30 ms (%)"
            if case == "dam_break"
            else "|mean mid deflection / beam theory - 1| (%)"
        )
        ax.set_ylabel("wall time per simulated second (s/s)")
        ax.set_title(CASE_NAMES[case], fontsize=10)
        ax.grid(alpha=0.3, which="both")
        if ax.lines:
            ax.legend(fontsize=7.5)
    configs = sorted({r.get("config", "") for r in rows})
    loaded = "; timings from a LOADED machine" if is_loaded(rows) else ""
    fig.suptitle(f"work-precision, MPS vs δ-SPH ({', '.join(configs)} grid{loaded})", fontsize=10)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _fmt(row: dict, key: str, scale: float = 1.0, digits: int = 3) -> str:
    x = _num(row, key)
    return "" if not np.isfinite(x) else f"{scale * x:.{digits}g}"


def page(rows: list[dict], csv_name: str = "validation/results/work_precision.csv") -> str:
    """docs/validation_work_precision.md from the CSV's rows."""
    configs = sorted({r.get("config", "") for r in rows})

    def listed(case: str, key: str) -> str:
        values = [f"{_num(r, key):g}" if key != "resolution" else r[key] for r in rows
                  if r["case"] == case and str(r.get(key, ""))]  # fmt: skip
        return ", ".join(dict.fromkeys(values)) or "none"

    out = [
        "# Validation: work-precision of MPS and δ-SPH (issue 23)",
        "",
        f"Generated by `validation/work_precision.py` from `{csv_name}`; do not edit by hand. "
        "Figure `docs/figures/work_precision.png`; tests `tests/scenarios/test_work_precision.py`.",
        "",
    ]
    if "reduced" in configs:
        out += [
            "**This page holds the reduced grid** (`--reduced`: coarser resolutions, the plate "
            "run to 0.1 s), run to check the pipeline, not the study; regenerate with "
            "`python validation/work_precision.py --fresh` on a quiet machine.",
            "",
        ]
    out += [
        "## Set-up",
        "",
        "| | dam break | coupled plate |",
        "|---|---|---|",
        "| scenario | MPS: `scenarios/dam_break_2d.toml`; δ-SPH: `validation/delta_sph_dam_break.py`'s "
        "(same geometry) | `scenarios/hydrostatic_plate_2d.toml` with `fluid.method` = mps / delta-sph |",
        "| reference | Koshizuka & Oka (1996) experiment, column L = 0.146 m, 2L high, tank 4L "
        "(`reference_data/`; references.md section 2) | clamped-clamped beam, w_mid = (rho_w g H + "
        "rho_s g h) L^4 / (384 D) = 6.86e-5 m (literature 6.85e-5 m; Fourey et al. 2017, "
        "Khayyer et al. 2018; references.md section 5) |",
        "| error | RMS relative error in Z = x/L over 0.5 <= T <= 3, after the best gate lag "
        "of the experiment in [0, 30 ms] (`validation/dam_break.py`, "
        "`validation/delta_sph_dam_break.py`); the raw (unshifted) error is in the table | "
        "\\|mean mid deflection over t >= 0.05 s / w_mid - 1\\| "
        "(`validation/delta_sph_hydrostatic_plate.py`'s window) |",
        f"| resolutions | {listed('dam_break', 'resolution')} | {listed('plate', 'resolution')} |",
        f"| run to | {listed('dam_break', 't_end_s')} s: the last Koshizuka & Oka point with "
        "T <= 3 is T = 2.719 (t = 0.2346 s), plus a probe interval | "
        f"{listed('plate', 't_end_s')} s (the plate study's 0.2 s on the full grid) |",
        f"| threads | {listed('dam_break', 'threads')} (numba) | {listed('plate', 'threads')} |",
        "| cost | wall time per simulated second: the results file's `wall_time` (set-up and "
        "numba's cache load included, compilation not: a warm-up run fills the cache first) "
        "/ end time | same |",
        "",
        "Reading the errors. The dam-break metric is the gap to one experiment, not a "
        "discretisation error: it does not go to zero with resolution (MPS's front converges, "
        'its curves at L/40 and L/80 differ by 1.3 %; docs/fluid.md, "Validation status"), '
        "and it has noise of its own: five MPS runs at L/40 that differ only in the pressure "
        "solver's tolerance spread over 1.6 percentage points of the shifted error "
        "(`docs/figures/dam_break_front_sensitivity.csv`). That spread is the dam break's "
        "`error_noise`. The plate's error is a time mean over the plate's oscillation about its "
        "static deflection; its `error_noise` is twice the mean's standard error from "
        f"{PLATE_BATCHES} batch means of the window. Below, two runs whose errors differ by "
        "less than the case's largest noise tie, and a finer run can score worse. The plate's "
        "cost is mostly the coupling's work per window (a fixed 0.2 ms window: the same number "
        "of windows at every spacing).",
        "",
        "## Results",
        "",
        "Error: dam break after the best lag <= 30 ms (lag in ms), plate |mean / w_mid - 1|; "
        "cost: wall s per simulated s from the results file; CPU s and the load averages of the "
        "whole subprocess.",
        "",
        "| case | method | resolution | threads | particles | steps | error | noise | raw error "
        "(lag) | wall s per sim s | CPU s | CPU/(wall x threads) | load start / end |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    order = {m: i for i, m in enumerate(METHODS)}
    for r in sorted(
        rows,
        key=lambda r: (
            CASES.index(r["case"]),
            order[r["method"]],
            int(_num(r, "threads")),
            -_num(r, "spacing_m"),
        ),
    ):
        head = (
            f"| {CASE_NAMES[r['case']]} | {METHOD_NAMES[r['method']]} | {r['resolution']} | "
            f"{r['threads']} |"
        )
        if r.get("status") != "finished":
            out.append(f"{head} | | {r.get('status', '')} | | | | | | |")
            continue
        raw = (
            f"{_fmt(r, 'error_raw', 100)} % ({_fmt(r, 'lag_ms', 1, 2)})"
            if _fmt(r, "error_raw")
            else ""
        )
        out.append(
            f"{head} {r.get('particles', '')} | {r.get('steps', '')} | "
            f"{_fmt(r, 'error', 100)} % | {_fmt(r, 'error_noise', 100, 2)} % | {raw} | "
            f"{_g(_num(r, 'wall_per_sim_s'))} | {_fmt(r, 'cpu_s')} | "
            f"{_fmt(r, 'cpu_per_wall_thread', 1, 2)} | "
            f"{_fmt(r, 'load_start', 1, 2)} / {_fmt(r, 'load_end', 1, 2)} |"
        )
    out += [
        "",
        "![work-precision](figures/work_precision.png)",
        "",
        "## Which method wins where",
        "",
    ]
    if is_loaded(rows):
        out += [
            'From timings on a loaded machine (below, "The machine"): the cost order of '
            "runs can be wrong, so these verdicts are the pipeline's, not the study's.",
            "",
        ]
    done = finished_rows(rows)
    for case in CASES:
        for threads in sorted({int(_num(r, "threads")) for r in rows}):
            sel = [r for r in rows if r["case"] == case and int(_num(r, "threads")) == threads]
            if sel:
                out.append(
                    f"- {CASE_NAMES[case]}, {threads} thread{'s' if threads > 1 else ''}: "
                    f"{who_wins(sel)}"
                )
    speedups = []
    for r in done:
        if int(_num(r, "threads")) != 2:
            continue
        one = [
            o
            for o in done
            if int(_num(o, "threads")) == 1
            and (o["case"], o["method"], o["level"]) == (r["case"], r["method"], r["level"])
        ]
        if one:
            s = _num(one[0], "wall_per_sim_s") / _num(r, "wall_per_sim_s")
            speedups.append(
                f"{METHOD_NAMES[r['method']]} {CASE_NAMES[r['case']]} {r['resolution']} {s:.2f}"
            )
    if speedups:
        out += ["", "Two threads against one (wall time ratio): " + "; ".join(speedups) + "."]
    out += ["", "## The machine", "", machine_note(rows), ""]
    return "\n".join(out)


def write_report(rows: list[dict], page_path: Path = PAGE, figure_path: Path = FIGURE) -> None:
    """The figure and the page from the CSV's rows."""
    figure(rows, figure_path)
    page_path.write_text(page(rows))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--threads", type=case_runner.thread_count, nargs="+", default=[1, 2],
                    help="numba thread counts (default 1 2)")  # fmt: skip
    ap.add_argument("--only", nargs="+", default=[], metavar="NAME",
                    help="keep runs whose method / case / level / thread count is named: "
                    "mps delta-sph dam_break plate coarse medium fine 1 2")  # fmt: skip
    ap.add_argument("--reduced", action="store_true", help="the small pipeline-check grid")
    ap.add_argument("--analyse-only", action="store_true", help="do not run, only analyse")
    ap.add_argument("--report-only", action="store_true",
                    help="only the figure and page, from the CSV")  # fmt: skip
    ap.add_argument("--retry-failed", action="store_true", help="rerun failed cases")
    ap.add_argument("--fresh", action="store_true",
                    help="delete the selected runs' results first: timings of one machine state")  # fmt: skip
    args = ap.parse_args(argv)
    if args.report_only:
        write_report(read_csv(CSV))
        print(f"wrote {FIGURE} and {PAGE} from {CSV}")
        return 0
    config = "reduced" if args.reduced else "full"
    cases = all_cases(config, tuple(dict.fromkeys(args.threads)), tuple(args.only))
    delta_sph_dam_break.SCENARIO.parent.mkdir(parents=True, exist_ok=True)
    delta_sph_dam_break.SCENARIO.write_text(delta_sph_dam_break.SCENARIO_TEXT)
    RUNS.mkdir(parents=True, exist_ok=True)
    if args.fresh and not args.analyse_only:
        delete_results(cases)
    if not args.analyse_only:
        todo = [c for c in cases if case_runner.read_status(c.path) != "finished"]
        est = estimate_seconds(todo) + (WARMUP_S if todo else 0.0)
        print(f"{len(cases)} runs, {len(todo)} to do: about {est / 60:.1f} min on a quiet "
              f"2-core machine (load now {os.getloadavg()[0]:.2f})", flush=True)  # fmt: skip
        t0 = time.perf_counter()
        warm_up(todo)
        for c in todo:
            run_case(c, args.retry_failed)
        print(f"runs took {(time.perf_counter() - t0) / 60:.1f} min")
    # the CSV holds the whole grid (1 and 2 threads and any asked for), run or not: a filtered
    # run does not drop the rows of the others
    grid = all_cases(config, tuple(sorted({1, 2, *args.threads})), ())
    rows = [analyse_case(c) for c in grid]
    write_csv(rows, CSV, COLUMNS, CSV_COMMENT)
    write_report(rows)
    for r in rows:
        print(f"{r['case']:9} {r['method']:9} {r['resolution']:>8} {r['threads']} thr  "
              f"{r['status'][:30]:30}  error {_fmt(r, 'error', 100):>6} %  raw "
              f"{_fmt(r, 'error_raw', 100):>6} %  {_fmt(r, 'wall_per_sim_s'):>7} s/s")  # fmt: skip
    print(f"wrote {CSV}, {FIGURE}, {PAGE}")
    selected = {c.path.name for c in cases}
    return 0 if all(r["status"] == "finished" for r in rows if r["run"] in selected) else 1


if __name__ == "__main__":
    sys.exit(main())
