"""Command line: ``mpsfem run | structure | modes | validate | docs``.

The ``run`` contract (design brief): ``mpsfem run SCENARIO.toml [--out PATH] [--end-time T]
[--transport inproc|mpi|zenoh] [--participant fluid|structure] [--set key=value ...]
[--restart CHECKPOINT]``. A scenario with both ``[fluid]`` and ``[structure]`` is a coupled run
(``[coupling]`` optional, defaults otherwise):

* ``mpsfem run S.toml`` (inproc, one process);
* ``mpirun -n 2 mpsfem run S.toml --transport mpi`` (rank 0 fluid, rank 1 structure), or MPMD
  ``mpirun -n 1 mpsfem run S.toml --transport mpi --participant fluid : -n 1 mpsfem run S.toml
  --transport mpi --participant structure``;
* ``mpsfem run S.toml --transport zenoh --participant structure`` and ``... --participant
  fluid`` in two shells, or ``mpsfem run S.toml --transport zenoh`` (starts the structure itself).

BLAS runs single-threaded (``OPENBLAS_NUM_THREADS=1`` unless set): the structure's solves stay
bit-identical between processes and do not compete with the fluid's numba threads.
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # before numpy is imported anywhere

import argparse  # noqa: E402
import contextlib  # noqa: E402
import math  # noqa: E402
import signal  # noqa: E402
import sys  # noqa: E402
import threading  # noqa: E402
import warnings  # noqa: E402
from collections.abc import Iterator  # noqa: E402
from pathlib import Path  # noqa: E402

from mpsfem import __version__  # noqa: E402
from mpsfem.scenario.base import ScenarioError  # noqa: E402


def _positive_int(text: str) -> int:
    """argparse type: a whole number >= 1."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r}: must be a whole number >= 1") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"{text!r}: must be a whole number >= 1")
    return value


def _scenario_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("scenario", type=Path, help="scenario TOML file")
    p.add_argument(
        "--set",
        dest="overrides",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="override a scenario value by dotted path; VALUE is a TOML literal or a bare "
        "word taken as a string (--set fluid.spacing=0.004 --set fluid.pressure.solver=pcg_jacobi)",
    )


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="mpsfem", description="MPS-FEM fluid-structure interaction with particle methods"
    )
    parser.add_argument("--version", action="version", version=f"mpsfem {__version__}")
    sub = parser.add_subparsers(dest="command", required=True)

    run = sub.add_parser("run", help="run a scenario")
    _scenario_args(run)
    run.add_argument("--out", type=Path, help="results file (default: <scenario stem>.h5)")
    run.add_argument(
        "--end-time", type=float, help="simulated end time, s (overrides run.end_time)"
    )
    run.add_argument(
        "--transport",
        choices=["inproc", "mpi", "zenoh"],
        default=None,
        help="how the participants of a coupled scenario talk (default: "
        "[coupling.transport] kind, else inproc)",
    )
    run.add_argument(
        "--participant",
        choices=["fluid", "structure"],
        default=None,
        help="run one participant of a coupled scenario only (MPMD and zenoh launches)",
    )
    run.add_argument("--restart", type=Path, help="resume from this checkpoint file")
    run.add_argument("--no-progress", action="store_true", help="no progress bar")

    st = sub.add_parser("structure", help="run the structure alone under prescribed loads")
    _scenario_args(st)
    st.add_argument("--out", type=Path, help="results file (default: <scenario stem>.h5)")
    st.add_argument("--no-progress", action="store_true", help="no progress bar")

    modes = sub.add_parser(
        "modes", help="natural frequencies of the structure members, dry (in vacuo: no fluid)"
    )
    _scenario_args(modes)
    modes.add_argument("--count", type=_positive_int, default=6, help="number of modes (>= 1)")

    val = sub.add_parser(
        "validate",
        help="check a scenario; print particle counts, memory and time estimates, contact "
        "problems and a verdict (--full: every resolved value too)",
    )
    _scenario_args(val)
    val.add_argument(
        "--full", action="store_true", help="print every resolved value (JSON) before the summary"
    )

    docs = sub.add_parser("docs", help="write docs/scenarios.md from the scenario schema")
    docs.add_argument(
        "--out",
        type=Path,
        default=None,
        help="file to write (default: docs/scenarios.md of the mpsfem source checkout this "
        "program runs from; elsewhere --out is needed)",
    )

    from mpsfem.tools.commands import add_tool_parsers

    add_tool_parsers(sub)  # plot, sweep
    return parser


def _set_threads(n: int | None) -> None:
    if n is None:
        return
    import numba

    numba.set_num_threads(min(n, numba.config.NUMBA_NUM_THREADS))


def _cmd_run(args: argparse.Namespace) -> int:
    from mpsfem.coupler.errors import CouplingError
    from mpsfem.results.disk_space import DiskFullError
    from mpsfem.results.xdmf import xdmf_path
    from mpsfem.scenario.loader import load_scenario
    from mpsfem.simulation import RunFailed

    loaded = load_scenario(args.scenario, args.overrides)
    sc = loaded.scenario
    if args.end_time is not None and not (math.isfinite(args.end_time) and args.end_time > 0):
        raise ScenarioError([f"--end-time = {args.end_time}: must be a finite number > 0"])
    if args.end_time is not None and sc.structure is not None:
        from mpsfem.scenario.limits import MAX_STRUCTURE_STEPS

        steps = args.end_time / sc.structure.time.dt
        if steps > MAX_STRUCTURE_STEPS:
            raise ScenarioError(
                [
                    f"--end-time = {args.end_time}: with structure.time.dt = "
                    f"{sc.structure.time.dt} makes {steps:.3g} structure steps; at most "
                    f"{MAX_STRUCTURE_STEPS:.0e} allowed"
                ]
            )
    out = args.out or Path.cwd() / f"{loaded.stem}.h5"
    problem = output_problem(out, args.restart)
    if problem:
        print(f"error: {problem}", file=sys.stderr)
        return 2
    _set_threads(sc.run.threads)
    progress = False if args.no_progress else None
    coupled = sc.fluid is not None and sc.structure is not None
    if sc.fluid is None:
        print(
            f"error: {args.scenario} has no [fluid] section; use 'mpsfem structure' for a "
            "structure-only scenario",
            file=sys.stderr,
        )
        return 2
    if not coupled and (args.participant or args.transport not in (None, "inproc")):
        print(
            f"error: --transport {args.transport} / --participant {args.participant}: "
            f"{args.scenario} is not a coupled scenario (it has no [structure] section)",
            file=sys.stderr,
        )
        return 2
    if not coupled:
        problem = single_process_problem(f"{args.scenario} is a fluid-only scenario")
        if problem:
            print(f"error: {problem}", file=sys.stderr)
            return 2
    try:
        with interrupt_as_stop_request():
            summary = _launch(args, loaded, out, progress, coupled)
        if summary is None:  # this process was the structure participant
            return 0
    except (RunFailed, CouplingError, DiskFullError) as exc:  # CouplingError: the peer never
        # came, or left; DiskFullError: no room for the results file before the first step
        print(f"error: {exc}", file=sys.stderr)
        return 1
    except ValueError as exc:  # bad launch options (roles, ranks), caught before any compute
        print(f"error: {exc}", file=sys.stderr)
        return 2
    sidecar = xdmf_path(summary.results)
    print(
        f"finished t = {summary.t:.6g} s in {summary.steps} steps, {summary.wall_time:.1f} s wall; "
        f"results {summary.results}"
        + (f" (ParaView: {sidecar})" if sidecar.is_file() else "")
        + f", checkpoint {summary.checkpoint}\n"
        f"plot the probes with: mpsfem plot {summary.results}"
    )
    return 0


#: the status reason of a run stopped by Ctrl-C (``failed: interrupted (SIGINT)``)
INTERRUPTED = "interrupted (SIGINT)"


@contextlib.contextmanager
def interrupt_as_stop_request() -> Iterator[None]:
    """Within the block, a first SIGINT (Ctrl-C) asks the run to stop at the end of its current
    step or window, as SIGTERM does: it checkpoints the last good state and leaves the status
    ``failed: interrupted (SIGINT)``. Raised as KeyboardInterrupt at once, it surfaced inside a
    numba call as ``SystemError: CPUDispatcher(...)`` and left ``failed: `` with no reason. A
    second SIGINT restores the previous handler and interrupts at once (a stuck run)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    from mpsfem import simulation

    previous = signal.getsignal(signal.SIGINT)

    def on_sigint(signum, frame) -> None:  # noqa: ARG001
        if simulation._stop_request:  # the second Ctrl-C: stop now
            signal.signal(signal.SIGINT, previous)
            raise KeyboardInterrupt
        simulation._stop_request.append(INTERRUPTED)
        print(
            "\nSIGINT: stopping at the end of this step (checkpoint, results closed); press "
            "Ctrl-C again to stop at once",
            file=sys.stderr,
            flush=True,
        )

    signal.signal(signal.SIGINT, on_sigint)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)


def _launch(args: argparse.Namespace, loaded, out: Path, progress, coupled: bool):
    """Run the fluid-only or coupled scenario; None where this process served the structure."""
    from mpsfem.simulation import run_coupled, run_fluid

    if not coupled:
        return run_fluid(loaded, out, args.end_time, args.restart, progress=progress)
    child = ["run", str(args.scenario), "--transport", "zenoh", "--no-progress"]
    for item in args.overrides:
        child += ["--set", item]
    return run_coupled(
        loaded,
        out,
        args.end_time,
        args.restart,
        progress=progress,
        transport=args.transport,
        participant=args.participant,
        child_argv=child,
    )


def single_process_problem(what: str) -> str | None:
    """Why this process must not run ``what`` (a one-process run), or None.

    Under ``mpirun -n N`` (N > 1) every rank would run the whole of it and write the same
    results file; only a coupled run splits into ranks (``--transport mpi``)."""
    from mpsfem.coupler.launch import mpi_job_size

    job = mpi_job_size()
    if job is None:
        return None
    n, var = job
    return (
        f"this process is one of {n} MPI ranks ({var}={n}), but {what}: it runs in one process, "
        "so every rank would run it and write the same results file. Start it without mpirun "
        "(run.threads sets its numba threads); only a coupled scenario runs under mpirun, with "
        "--transport mpi"
    )


def output_problem(out: Path, restart: Path | None = None) -> str | None:
    """Why ``--out`` / ``--restart`` cannot work (checked before any compute), or None.

    The results file's folder must exist; a restart needs its checkpoint file and the results
    file of the run it continues (the restart appends to it)."""
    if not out.parent.is_dir():
        return f"--out {out}: the folder {out.parent} does not exist"
    if out.is_dir():
        return f"--out {out}: is a folder; give the results file's path"
    if restart is not None:
        if not restart.is_file():
            return f"--restart {restart}: no such checkpoint file"
        if not out.is_file():
            return (
                f"--restart {restart} --out {out}: the results file does not exist; a restart "
                "continues the results file of the run that wrote the checkpoint (give its path "
                "with --out)"
            )
    return None


def _cmd_validate(args: argparse.Namespace) -> int:
    from mpsfem.scenario.loader import load_scenario

    loaded = load_scenario(args.scenario, args.overrides)
    import json

    from mpsfem.scenario_report import report

    if args.full:
        print(json.dumps(loaded.scenario.model_dump(mode="json"), indent=2))
    if loaded.scenario.fluid is not None:
        from mpsfem.fluid_mps.geometry import lattice_notes

        for note in lattice_notes(loaded.scenario.fluid):
            print(f"note: {note}", file=sys.stderr)
    summary = report(loaded.scenario, loaded.scenario.title)
    for line in summary.lines:
        print(line)
    print(summary.verdict)
    return 0


def source_docs_path() -> Path | None:
    """docs/scenarios.md of the source checkout this package runs from, or None (installed)."""
    path = Path(__file__).resolve().parents[2] / "docs" / "scenarios.md"
    return path if path.is_file() else None


def _cmd_docs(args: argparse.Namespace) -> int:
    from mpsfem.scenario.docs import write_scenario_docs

    out = args.out if args.out is not None else source_docs_path()
    if out is None:
        print(
            "error: mpsfem runs from an installed package, not a source checkout, so there is no "
            "docs/scenarios.md to regenerate; give the file to write with --out PATH",
            file=sys.stderr,
        )
        return 2
    if not out.parent.is_dir():
        print(f"error: --out {out}: the folder {out.parent} does not exist", file=sys.stderr)
        return 2
    path = write_scenario_docs(out)
    print(f"wrote {path}")
    return 0


_python_formatwarning = warnings.formatwarning


def _format_warning(message, category, filename, lineno, line=None) -> str:
    """mpsfem's own warnings (the scenario's links and light members, large rotations, the
    coupler's) as one ``warning: ...`` line like the CLI's ``error:`` and ``note:`` lines;
    Python's form, with the source line, for everyone else's."""
    if category.__module__.startswith("mpsfem."):
        return f"warning: {message}\n"
    return _python_formatwarning(message, category, filename, lineno, line)


def main(argv: list[str] | None = None) -> int:
    warnings.formatwarning = _format_warning
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        if args.command == "run":
            return _cmd_run(args)
        if args.command == "validate":
            return _cmd_validate(args)
        if args.command == "docs":
            return _cmd_docs(args)
        if args.command in ("plot", "sweep"):
            from mpsfem.tools.commands import run_tool

            return run_tool(args)
        if args.command in ("structure", "modes"):
            from mpsfem.structure_fem.standalone import cli_main

            problem = output_problem(args.out) if getattr(args, "out", None) else None
            problem = problem or single_process_problem(
                f"'mpsfem {args.command}' runs the structure alone"
            )
            if problem:
                print(f"error: {problem}", file=sys.stderr)
                return 2

            return cli_main(args)
    except ScenarioError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    parser.error(f"unknown command {args.command}")
    return 2


if __name__ == "__main__":
    sys.exit(main())
