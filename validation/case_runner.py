"""Resumable runs of one validation case: what every study script in validation/ shares.

A case is one ``mpsfem run`` of a scenario with ``--set`` overrides into its own results file.
``ensure_case`` skips a finished file, leaves a file another process is writing alone, reports a
failed one (rerun only when asked), resumes one a kill or a signal stopped from its checkpoint and
runs a missing one.
"""

from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
from collections.abc import Iterable, Iterator, Sequence
from pathlib import Path

import h5py

from mpsfem.results.checkpoint import default_checkpoint_path

ROOT = Path(__file__).resolve().parents[1]


def thread_count(text: str) -> int:
    """argparse type of ``--threads``: a whole number >= 1, refused before any run starts."""
    try:
        n = int(text)
    except ValueError:
        n = 0
    if n < 1:
        raise argparse.ArgumentTypeError(f"--threads = {text!r}: must be a whole number >= 1")
    return n


def add_run_options(ap: argparse.ArgumentParser) -> None:
    """The options every study script shares: ``--threads`` (numba threads per run, default 1,
    checked by :func:`thread_count`), ``--analyse-only`` and ``--retry-failed``."""
    ap.add_argument(
        "--threads", type=thread_count, default=1, help="numba threads per run (default 1)"
    )
    ap.add_argument("--analyse-only", action="store_true", help="do not run, only analyse")
    ap.add_argument("--retry-failed", action="store_true", help="rerun failed cases")


def read_status(path: Path) -> str | None:
    """The results file's ``status`` attribute, None if there is no file; 'locked' when another
    process is writing it."""
    if not path.is_file():
        return None
    try:
        with h5py.File(path, "r") as h5:
            return str(h5.attrs.get("status", "unknown"))
    except OSError as exc:
        if "lock" in str(exc).lower():
            return "locked"
        return f"unreadable: {exc}"


def analysable(status: str | None) -> bool:
    """A results file that exists and can be read now (finished, stopped or still running),
    not one another process holds locked or one h5py cannot open."""
    return status is not None and status != "locked" and not status.startswith("unreadable")


def readable_results(paths: Iterable[Path]) -> Iterator[tuple[Path, str]]:
    """(path, status) of each results file of ``paths`` that :func:`analysable` admits,
    checkpoints (``*.ckpt.h5``) left out; says which others it skipped and why."""
    for path in paths:
        if path.name.endswith(".ckpt.h5"):
            continue
        status = read_status(path)
        if not analysable(status):
            print(f"{path.name}: {status}, skipped")
            continue
        yield path, status


#: status texts of a run stopped from outside (SIGTERM, Ctrl-C), which resume like a killed one
SIGNAL_STATUS = ("received signal", "returned a result with an exception set", "KeyboardInterrupt")


def resumable(status: str | None) -> bool:
    """A run a kill interrupted (``running``) or a signal stopped."""
    return status == "running" or (
        status is not None
        and status.startswith("failed")
        and any(s in status for s in SIGNAL_STATUS)
    )


#: ``python -c`` text of an ``mpsfem run`` whose restart may change any scenario key (a study's
#: branch from another run's state, :func:`physics_branch`): the check is replaced by one that
#: prints every changed key instead of refusing it
PHYSICS_BRANCH_CLI = """
import sys
import mpsfem.simulation as sim
from mpsfem.scenario.compare import restart_differences


def check(loaded, restart, log):
    resolved, _, _ = sim.read_checkpoint_scenario(restart)
    now = loaded.scenario.model_dump(mode="json")
    for key, a, b in restart_differences(resolved or {}, now):
        log(f"physics branch: {key}: checkpoint {a!r}, now {b!r}")


sim.check_restart_scenario = check
import mpsfem.coupler.coupling_scheme as cs

_load = cs.CouplingScheme.load_state_dict


def load(self, state):
    # another acceleration kind than the checkpoint's: its saved history does not fit; it
    # starts without one (as in a run's first window)
    acc = getattr(self, "acceleration", None)
    if acc is not None:
        inner = acc.load_state_dict

        def tolerant(saved):
            try:
                inner(saved)
            except (KeyError, ValueError) as exc:
                print(f"physics branch: the checkpoint's acceleration state does not fit "
                      f"({type(exc).__name__}: {exc}); the acceleration starts without history",
                      flush=True)

        acc.load_state_dict = tolerant
    _load(self, state)


cs.CouplingScheme.load_state_dict = load
from mpsfem.cli import main

sys.exit(main(sys.argv[1:]))
"""


def run_scenario(
    scenario: Path,
    out: Path,
    overrides: Sequence[str],
    threads: int,
    restart: Path | None = None,
    tag: str = "",
    physics_branch: bool = False,
) -> int:
    """``mpsfem run`` of ``scenario`` in a subprocess on ``threads`` numba threads; its exit
    code. ``physics_branch``: the restart may change any key (:data:`PHYSICS_BRANCH_CLI`)."""
    head = ["-c", PHYSICS_BRANCH_CLI] if physics_branch else ["-m", "mpsfem.cli"]
    cmd = [sys.executable, *head, "run", str(scenario), "--out", str(out)]
    for item in overrides:
        cmd += ["--set", item]
    cmd.append("--no-progress")
    if restart is not None:
        cmd += ["--restart", str(restart)]
    env = dict(
        os.environ,
        NUMBA_NUM_THREADS=str(threads),
        OMP_NUM_THREADS=str(threads),
        OPENBLAS_NUM_THREADS="1",
    )
    shown = cmd[3:] if physics_branch else cmd[2:]
    print(
        f"{tag} {'physics branch: ' if physics_branch else ''}{' '.join(shown)}".strip(), flush=True
    )
    return subprocess.run(cmd, env=env, cwd=ROOT, check=False).returncode


def ensure_case(
    scenario: Path,
    out: Path,
    overrides: Sequence[str],
    threads: int,
    retry: bool,
    tag: str = "",
) -> str:
    """Run (or resume) one case unless its results file says finished; its final status."""
    status = read_status(out)
    ckpt = default_checkpoint_path(out)
    name = f"{tag} {out.name}".strip()
    if status == "finished":
        print(f"{name}: finished, skipped")
        return status
    if status == "locked":
        print(f"{name}: locked (another run is writing it), skipped")
        return status
    if status is not None and status.startswith("failed") and not resumable(status) and not retry:
        print(f"{name}: {status} (rerun with --retry-failed)")
        return status
    restart = ckpt if resumable(status) and ckpt.is_file() else None
    if restart is not None:
        print(f"{name}: resuming from {ckpt.name}")
    elif out.exists():
        out.unlink()
    run_scenario(scenario, out, overrides, threads, restart, tag)
    return read_status(out) or "missing"


def case_status(
    scenario: Path,
    out: Path,
    overrides: Sequence[str],
    threads: int,
    analyse_only: bool,
    retry: bool,
    tag: str = "",
) -> str | None:
    """The case's status: read from its results file with ``analyse_only`` (None if there is
    none), else after :func:`ensure_case` ran or resumed it."""
    if analyse_only:
        return read_status(out)
    return ensure_case(scenario, out, overrides, threads, retry, tag)


def finished_cases(
    scenario: Path,
    cases: dict,
    threads: int,
    analyse_only: bool,
    retry: bool,
) -> dict:
    """Run (or read) every case of ``cases`` (key -> (results path, overrides, tag)) with
    :func:`case_status`; returns {key: results path} of the finished ones and prints the status
    of the others."""
    finished = {}
    for key, (out, overrides, tag) in cases.items():
        status = case_status(scenario, out, overrides, threads, analyse_only, retry, tag)
        if status == "finished":
            finished[key] = out
        else:
            print(f"{tag}: {status}, not analysed")
    return finished


def copy_for_branch(source: Path, source_ckpt: Path, out: Path) -> None:
    """Copy a finished run and its checkpoint to ``out`` as the start of a branch, its status
    set to ``running`` (a run interrupted at the branch time): should the continuation not start
    (a restart refused before compute, a kill), a rerun resumes it from the copied checkpoint
    instead of skipping a copy that says ``finished`` at the base's end."""
    shutil.copyfile(source, out)
    shutil.copyfile(source_ckpt, default_checkpoint_path(out))
    with h5py.File(out, "a") as h5:
        h5.attrs["status"] = "running"


def branch_case(
    scenario: Path,
    base: Path,
    base_overrides: Sequence[str],
    out: Path,
    overrides: Sequence[str],
    at: float,
    threads: int,
    retry: bool,
    tag: str = "",
) -> None:
    """Run ``base`` (its overrides must write a checkpoint at ``at`` s and end there) unless
    finished, copy it and its checkpoint to ``out`` and continue ``out`` from there with
    ``overrides`` (``mpsfem run --restart``: only the keys a restart may change may differ).
    Says why when the base did not finish or has no checkpoint at ``at``."""
    from mpsfem.results.checkpoint import read_checkpoint

    status = ensure_case(scenario, base, base_overrides, threads, retry, f"{tag} base".strip())
    ckpt = default_checkpoint_path(base)
    if status != "finished" or not ckpt.is_file():
        print(f"{tag}: base {base.name} is {status}; no branch")
        return
    _, meta, _ = read_checkpoint(ckpt)
    t = float((meta["scheme"] if "scheme" in meta else meta["fluid"])["t"])  # coupled / fluid
    if abs(t - at) > 1e-9:
        print(f"{tag}: the checkpoint of {base.name} is at t = {t:g} s, not {at:g}; no branch")
        return
    if base != out:
        copy_for_branch(base, ckpt, out)
    run_scenario(scenario, out, overrides, threads, default_checkpoint_path(out), tag)


def physics_branch(
    scenario: Path,
    source: Path,
    out: Path,
    overrides: Sequence[str],
    threads: int,
    retry: bool,
    tag: str = "",
) -> str:
    """Continue ``source`` (a finished run with a checkpoint at its end) into ``out`` under
    ``overrides`` that may change any scenario key, physics included: a study's what-if from a
    shared state (e.g. frozen surface flags or another wet threshold from the same 1.55 s or
    1.85 s state), which an ``mpsfem run --restart`` refuses. Every changed key is printed into
    the run's log. ``out`` holds ``source``'s record up to the branch time, then the branch's.
    A finished ``out`` is skipped, one stopped by a signal resumes (then as an ordinary restart
    of itself: its own checkpoint carries the branch's scenario). Returns ``out``'s status."""
    status = read_status(out)
    if status == "finished":
        print(f"{tag} {out.name}: finished, skipped".strip())
        return status
    if status is not None and not resumable(status) and not retry:
        print(f"{tag} {out.name}: {status} (rerun with --retry-failed)".strip())
        return status
    ckpt = default_checkpoint_path(out)
    if resumable(status) and ckpt.is_file():
        print(f"{tag} {out.name}: resuming from {ckpt.name}".strip())
        run_scenario(scenario, out, overrides, threads, ckpt, tag)
        return read_status(out) or "missing"
    src_ckpt = default_checkpoint_path(source)
    if read_status(source) != "finished" or not src_ckpt.is_file():
        print(f"{tag}: {source.name} is {read_status(source)} or has no checkpoint; no branch")
        return "missing"
    copy_for_branch(source, src_ckpt, out)
    run_scenario(scenario, out, overrides, threads, ckpt, tag, physics_branch=True)
    return read_status(out) or "missing"
