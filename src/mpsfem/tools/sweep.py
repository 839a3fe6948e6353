"""``mpsfem sweep``: run the Cartesian product of scenario parameter values, resumably.

Every case is one child process ``python -m mpsfem.cli structure|run SCENARIO --out
<dir>/<case>/results.h5 --no-progress --set ...`` (``structure`` for a scenario without
``[fluid]``, ``run`` otherwise), started in its own folder ``<dir>/<case>/`` (name from the
parameter values, :mod:`mpsfem.tools.grid`) with its output in ``run.log``. Up to ``jobs`` run at
once, each with ``NUMBA_NUM_THREADS = max(1, cpu_count // jobs)``.

Every case's scenario is validated before the first one starts. A case is *complete* when its
``results.h5`` has root attribute ``status == "finished"`` (set by the run loops when they reach
the end time) and was written from the same scenario text and the same ``--set`` list (root
attributes ``scenario`` and ``overrides``); complete cases are not run again. After each child
exits, ``case.json`` records its parameters, exit status and wall time. A failed case is
reported and the others go on; the sweep's exit status is 1 if any case failed.
"""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
import threading
import time
from concurrent.futures import ThreadPoolExecutor, as_completed
from dataclasses import dataclass, field
from pathlib import Path

from mpsfem.scenario.base import ScenarioError
from mpsfem.tools import ToolError
from mpsfem.tools.grid import Case, GridAxis, make_cases, parse_grid_arg
from mpsfem.tools.peaks import Peak, PeakSpec, check_peak_specs, parse_peak_arg

RESULTS_NAME = "results.h5"
CASE_RECORD = "case.json"
LOG_NAME = "run.log"


@dataclass
class SweepPlan:
    """A validated sweep: scenario, cases, what every child gets."""

    scenario: Path
    text: str
    axes: list[GridAxis]
    cases: list[Case]
    base_overrides: list[str]  # --set items and run.end_time, before each case's own
    runner: str  # "structure", "fluid" or "coupled"
    out_dir: Path
    peaks: list[PeakSpec]

    @property
    def subcommand(self) -> str:
        return "structure" if self.runner == "structure" else "run"

    def overrides(self, case: Case) -> list[str]:
        return [*self.base_overrides, *case.overrides()]

    def case_dir(self, case: Case) -> Path:
        return self.out_dir / case.name

    def command(self, case: Case) -> list[str]:
        """The child's command line."""
        cmd = [sys.executable, "-m", "mpsfem.cli", self.subcommand, str(self.scenario)]
        cmd += ["--out", str(self.case_dir(case) / RESULTS_NAME), "--no-progress"]
        for item in self.overrides(case):
            cmd += ["--set", item]
        return cmd


@dataclass
class CaseOutcome:
    """What became of one case."""

    case: Case
    status: str  # "finished" or "failed"
    reused: bool = False
    wall_time: float = float("nan")  # s, child process start to exit
    run_wall_time: float = float("nan")  # s, the run's own wall time (results attribute)
    returncode: int | None = None
    error: str = ""
    peaks: dict[str, Peak] = field(default_factory=dict)


def _key_of(item: str) -> str:
    return item.partition("=")[0].strip()


def plan_sweep(
    scenario: str | Path,
    grid: list[str],
    *,
    out_dir: str | Path | None = None,
    overrides: list[str] = (),
    end_time: float | None = None,
    peaks: list[str] = (),
) -> SweepPlan:
    """Parse and validate a sweep; raises :class:`ScenarioError` / :class:`ToolError` listing
    every problem before anything runs."""
    from mpsfem.scenario.loader import load_scenario_text, parse_override

    scenario = Path(scenario).resolve()
    if not scenario.is_file():
        raise ScenarioError([f"scenario file {str(scenario)!r} does not exist"])
    if not grid:
        raise ToolError("give at least one --grid key=v1,v2,...")
    axes = [parse_grid_arg(g) for g in grid]
    base = list(overrides)
    for item in base:
        parse_override(item)  # the --set syntax errors first
    if end_time is not None:
        if not (math.isfinite(end_time) and end_time > 0):
            raise ScenarioError([f"--end-time = {end_time}: must be finite and > 0"])
        if "run.end_time" in {_key_of(o) for o in base}:
            raise ScenarioError(["--end-time and --set run.end_time: give the end time once"])
        base.append(f"run.end_time={end_time!r}")
    problems = []
    set_keys = {_key_of(o) for o in base}
    for a in axes:
        if a.key in set_keys:
            flag = "--end-time" if a.key == "run.end_time" and end_time is not None else "--set"
            problems.append(f"--grid {a.key}: also given by {flag}; give it in one place")
    if problems:
        raise ScenarioError(problems)
    cases = make_cases(axes)
    text = scenario.read_text(encoding="utf-8")
    seen: dict[str, list[str]] = {}
    runner = None
    for case in cases:
        try:
            loaded = load_scenario_text(text, [*base, *case.overrides()], scenario)
        except ScenarioError as exc:
            for p in exc.problems:
                seen.setdefault(p, []).append(case.label)
            continue
        sc = loaded.scenario
        runner = runner or (
            "structure" if sc.fluid is None else "fluid" if sc.structure is None else "coupled"
        )
        for p in check_peak_specs([parse_peak_arg(x) for x in peaks], sc, runner):
            seen.setdefault(p, []).append(case.label)
    if seen:
        lines = []
        for p, where in seen.items():
            if len(where) < len(cases):
                p += f"  [case{'s' if len(where) > 1 else ''} {'; '.join(where)}]"
            lines.append(p)
        raise ScenarioError(lines, str(scenario))
    out = (Path(out_dir) if out_dir is not None else Path(f"{scenario.stem}_sweep")).resolve()
    return SweepPlan(
        scenario, text, axes, cases, base, runner, out, [parse_peak_arg(x) for x in peaks]
    )


def completed(plan: SweepPlan, case: Case) -> tuple[bool, str, float]:
    """(complete?, why not, the run's wall time) for ``case`` from its results file."""
    import h5py

    path = plan.case_dir(case) / RESULTS_NAME
    if not path.is_file():
        return False, "", float("nan")
    try:
        with h5py.File(path, "r") as h5:
            status = str(h5.attrs.get("status", ""))
            same = h5.attrs.get("scenario") == plan.text and json.loads(
                h5.attrs.get("overrides", "null")
            ) == plan.overrides(case)
            wall = float(h5.attrs.get("wall_time", float("nan")))
    except (OSError, ValueError) as exc:
        return False, f"results file unreadable ({exc})", float("nan")
    if not same:
        return False, "scenario or options changed since", wall
    if status != "finished":
        return False, f"results status {status!r}", wall
    return True, "", wall


def _last_line(path: Path) -> str:
    try:
        lines = [ln.strip() for ln in path.read_text(errors="replace").splitlines() if ln.strip()]
    except OSError:
        return ""
    return lines[-1] if lines else ""


class _Children:
    """Running child processes, so an interrupt can stop them all."""

    def __init__(self) -> None:
        self.lock = threading.Lock()
        self.procs: set[subprocess.Popen] = set()
        self.stopping = False

    def start(self, cmd, **kw) -> subprocess.Popen | None:
        with self.lock:
            if self.stopping:
                return None
            proc = subprocess.Popen(cmd, **kw)
            self.procs.add(proc)
            return proc

    def done(self, proc: subprocess.Popen) -> None:
        with self.lock:
            self.procs.discard(proc)

    def stop_all(self) -> None:
        with self.lock:
            self.stopping = True
            procs = list(self.procs)
        for p in procs:
            p.terminate()
        for p in procs:
            try:
                p.wait(timeout=10)
            except subprocess.TimeoutExpired:
                p.kill()


@dataclass
class SweepResult:
    """Outcome of :func:`run_sweep`: one :class:`CaseOutcome` per case (grid order), the
    summary CSV, the peak plots and problems reading peaks."""

    outcomes: list[CaseOutcome]
    summary: Path
    plots: list[Path]
    problems: list[str]

    @property
    def ok(self) -> bool:
        return not self.problems and all(o.status == "finished" for o in self.outcomes)


def choose_jobs(requested: int | None, n_cases: int, cpus: int) -> tuple[int, int]:
    """(cases at once, NUMBA_NUM_THREADS per child): ``requested`` or ``cpus // 2`` (at least 1),
    never more than ``n_cases``; threads ``max(1, cpus // jobs)`` so children do not
    oversubscribe the machine."""
    jobs = requested if requested is not None else max(1, cpus // 2)
    jobs = max(1, min(jobs, n_cases))
    return jobs, max(1, cpus // jobs)


def run_sweep(plan: SweepPlan, jobs: int | None = None, log=print) -> SweepResult:
    """Run the cases of ``plan`` that are not complete (``jobs`` at once, default
    ``max(1, cpu_count // 2)``, at most the number of cases to run) and write ``summary.csv`` and
    the peak plots into ``plan.out_dir``."""
    from mpsfem.tools.sweep_report import attach_peaks, plot_peaks, write_summary

    n = len(plan.cases)
    width = len(str(n))
    tag = {c.index: f"[{c.index + 1:>{width}}/{n}]" for c in plan.cases}
    outcomes: dict[int, CaseOutcome] = {}
    todo: list[Case] = []
    notes: list[str] = []
    for case in plan.cases:
        ok, why, wall = completed(plan, case)
        if ok:
            o = outcomes[case.index] = _reused(plan, case, wall)
            notes.append(f"{tag[case.index]} reused  {case.label} ({o.wall_time:.2f} s earlier)")
        else:
            todo.append(case)
            if why:
                notes.append(f"{tag[case.index]} rerun   {case.label}: {why}")
    jobs, threads = choose_jobs(jobs, len(todo), os.cpu_count() or 1)
    plan.out_dir.mkdir(parents=True, exist_ok=True)
    shape = " x ".join(f"{len(a.values)} {a.key}" for a in plan.axes)
    log(
        f"sweep: {n} cases ({shape}) of {plan.scenario.name} in {plan.out_dir}; "
        f"{len(todo)} to run, {n - len(todo)} complete; {jobs} at a time, "
        f"NUMBA_NUM_THREADS={threads} each"
    )
    for note in notes:
        log(note)
    env = dict(os.environ, NUMBA_NUM_THREADS=str(threads))
    children = _Children()
    print_lock = threading.Lock()

    def say(msg: str) -> None:
        with print_lock:
            log(msg)

    def run_one(case: Case) -> CaseOutcome:
        folder = plan.case_dir(case)
        folder.mkdir(parents=True, exist_ok=True)
        (folder / CASE_RECORD).unlink(missing_ok=True)
        say(f"{tag[case.index]} start   {case.label}")
        t0 = time.perf_counter()
        with open(folder / LOG_NAME, "w") as fh:
            proc = children.start(
                plan.command(case),
                cwd=folder,
                env=env,
                stdin=subprocess.DEVNULL,
                stdout=fh,
                stderr=subprocess.STDOUT,
            )
            if proc is None:
                return CaseOutcome(case, "failed", error="interrupted before it started")
            rc = proc.wait()
            children.done(proc)
        wall = time.perf_counter() - t0
        ok, why, run_wall = completed(plan, case)
        if children.stopping:
            out = CaseOutcome(case, "failed", False, wall, run_wall, rc, "stopped by interrupt")
            say(f"{tag[case.index]} stopped {case.label} after {wall:.2f} s")
        elif rc == 0 and ok:
            out = CaseOutcome(case, "finished", False, wall, run_wall, rc)
            say(f"{tag[case.index]} done    {case.label} in {wall:.2f} s")
        else:
            err = _last_line(folder / LOG_NAME) or why or "no output"
            out = CaseOutcome(case, "failed", False, wall, run_wall, rc, err)
            say(
                f"{tag[case.index]} FAILED  {case.label}: exit {rc} after {wall:.2f} s: {err} "
                f"(log {folder / LOG_NAME})"
            )
        _write_record(plan, out)
        return out

    t_start = time.perf_counter()
    pool = ThreadPoolExecutor(max_workers=jobs)
    try:
        futures = [pool.submit(run_one, c) for c in todo]
        for fut in as_completed(futures):
            o = fut.result()
            outcomes[o.case.index] = o
    except BaseException:
        pool.shutdown(wait=False, cancel_futures=True)
        children.stop_all()
        raise
    pool.shutdown()
    ordered = [outcomes[c.index] for c in plan.cases]
    peak_problems = attach_peaks(plan, ordered)
    summary = write_summary(plan, ordered)
    plots = plot_peaks(plan, ordered)
    failed = [o for o in ordered if o.status != "finished"]
    reused = sum(o.reused for o in ordered)
    for p in peak_problems:
        log(f"warning: {p}")
    ran = [o for o in ordered if not o.reused and o.status == "finished"]
    overhead = ""
    if ran:
        extra = [o.wall_time - o.run_wall_time for o in ran]
        overhead = f"; process overhead {sum(extra) / len(extra):.2f} s per case"
    log(
        f"sweep: {n - len(failed)} finished ({reused} reused), {len(failed)} failed in "
        f"{time.perf_counter() - t_start:.1f} s wall{overhead}; summary {summary}"
        + (f"; {len(plots)} peak plots" if plots else "")
    )
    return SweepResult(ordered, summary, plots, peak_problems)


def _reused(plan: SweepPlan, case: Case, run_wall: float) -> CaseOutcome:
    wall = run_wall
    try:
        rec = json.loads((plan.case_dir(case) / CASE_RECORD).read_text())
        wall = float(rec.get("wall_time_s", wall))
    except (OSError, ValueError, TypeError):
        pass
    return CaseOutcome(case, "finished", True, wall, run_wall, 0)


def _write_record(plan: SweepPlan, o: CaseOutcome) -> None:
    rec = {
        "case": o.case.name,
        "parameters": dict(o.case.params),
        "overrides": plan.overrides(o.case),
        "command": plan.command(o.case),
        "status": o.status,
        "returncode": o.returncode,
        "wall_time_s": o.wall_time,
        "run_wall_time_s": o.run_wall_time,
        "error": o.error,
    }
    path = plan.case_dir(o.case) / CASE_RECORD
    path.write_text(json.dumps(rec, indent=2, default=str) + "\n")


def cli_main(args) -> int:
    """Entry for ``mpsfem sweep`` (argparse namespace of :mod:`mpsfem.tools.commands`)."""
    if args.jobs is not None and args.jobs < 1:
        print(f"error: --jobs {args.jobs}: must be >= 1", file=sys.stderr)
        return 2
    try:
        plan = plan_sweep(
            args.scenario,
            args.grid,
            out_dir=args.out,
            overrides=args.overrides,
            end_time=args.end_time,
            peaks=args.peaks or [],
        )
    except ToolError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    try:
        result = run_sweep(plan, args.jobs, log=lambda m: print(m, flush=True))
    except KeyboardInterrupt:
        print("sweep: interrupted; the running cases were stopped", file=sys.stderr)
        return 130
    return 0 if result.ok else 1
