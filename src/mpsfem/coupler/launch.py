"""Glue for the command line: which participant this process runs, and how it reaches the other.

    inproc   one process: the scheme calls both participants directly.
    mpi      ``mpirun -n 2 ...`` (rank 0 fluid, rank 1 structure) or MPMD with ``--participant``.
    zenoh    two processes with ``--participant fluid|structure``; without ``--participant`` the
             launcher starts the structure as a child process (:func:`spawn_structure`).

The fluid process builds the scheme with a :class:`~mpsfem.coupler.remote.RemoteParticipant`
as its structure (:func:`connect_structure`); the structure process runs :func:`serve_structure`.
On :class:`~mpsfem.coupler.errors.PeerLostError` the caller flushes its results and then calls
``transport.abort()`` (MPI: ends every rank so nothing hangs in ``MPI_Finalize``).
"""

from __future__ import annotations

import contextlib
import os
import signal
import subprocess
import sys
import threading
from collections.abc import Callable, Iterator, Sequence

from mpsfem.coupler.remote import RemoteParticipant, serve
from mpsfem.coupler.transport import Transport, open_transport
from mpsfem.coupler.transport.auth import TOKEN_ENV, TOKEN_FILE_ENV, new_run_token

__all__ = [
    "connect_structure",
    "deferred_signals",
    "mpi_job_size",
    "participant_role",
    "serve_structure",
    "spawn_structure",
]


#: environment variables in which MPI launchers give a process the number of ranks of its job
#: (MPICH/Hydra and Intel MPI, MPICH, Open MPI, MVAPICH)
MPI_SIZE_VARIABLES = ("PMI_SIZE", "MPI_LOCALNRANKS", "OMPI_COMM_WORLD_SIZE", "MV2_COMM_WORLD_SIZE")


def mpi_job_size(environ=None) -> tuple[int, str] | None:
    """(ranks, variable) when an MPI launcher started this process in a job of several ranks,
    from its environment (no MPI import: a job of one, or no launcher, gives None)."""
    environ = os.environ if environ is None else environ
    for name in MPI_SIZE_VARIABLES:
        try:
            n = int(environ.get(name, ""))
        except ValueError:
            continue
        if n > 1:
            return n, name
    return None


def participant_role(kind: str, participant: str | None) -> str | None:
    """This process's role: "fluid", "structure", or None for inproc (both) and for mpi without
    ``--participant`` (taken from the rank when the transport opens).

    Under ``mpirun -n 2`` a transport that runs the whole coupled simulation in this process
    (inproc; zenoh without ``--participant``, which starts its own structure) would run it in
    every rank, each writing the same results file: refused before any compute."""
    job = mpi_job_size()
    if job is not None and (kind == "inproc" or (kind == "zenoh" and participant is None)):
        from mpsfem.coupler.transport import TRANSPORTS

        n, var = job
        how = (
            "--transport inproc" if kind == "inproc" else "--transport zenoh without --participant"
        )
        raise ValueError(
            f"this process is one of {n} MPI ranks ({var}={n}), but {how} runs the whole coupled "
            "simulation in one process, so every rank would run it and write the same results "
            f"file. Under mpirun use --transport mpi (allowed: {', '.join(TRANSPORTS)}); inproc "
            "and zenoh runs are started without mpirun"
        )
    if participant is not None:
        if participant not in ("fluid", "structure"):
            raise ValueError(f"--participant {participant!r}: allowed fluid, structure")
        if kind == "inproc":
            raise ValueError('--participant needs --transport mpi or zenoh, not "inproc"')
        return participant
    if kind == "mpi":
        from mpi4py import MPI

        return ("fluid", "structure")[MPI.COMM_WORLD.Get_rank()]
    if kind == "zenoh":
        return "fluid"  # and the launcher starts the structure (spawn_structure)
    return None


#: the structure process this process started (:func:`spawn_structure`), watched while the fluid
#: waits for it: if it exits first (its port taken, a crash) the wait ends at once
_spawned: list[subprocess.Popen] = []


def _spawned_structure_exited() -> str | None:
    child = _spawned[-1] if _spawned else None
    if child is None or child.poll() is None:
        return None
    return (
        f"the structure process this run started (pid {child.pid}) exited with code "
        f"{child.returncode} before connecting (its messages above say why)"
    )


def connect_structure(config) -> tuple[RemoteParticipant, Transport]:
    """Fluid side: open ``config.transport`` and return the structure as a remote participant."""
    from mpsfem.coupler.transport import TRANSPORTS

    t = TRANSPORTS.get(config.transport.kind).from_config("fluid", config.transport)
    if hasattr(t, "watch"):
        t.watch = _spawned_structure_exited
    t.connect()
    return RemoteParticipant(t), t


def serve_structure(structure, config, log: Callable[[str], None] | None = None) -> int:
    """Structure side: open the transport, answer the fluid's requests until it finalises.

    SIGTERM and SIGINT are deferred while serving (:func:`deferred_signals`): the fluid side
    receives them too (``mpirun`` forwards them to every rank; Ctrl-C reaches the whole process
    group of a spawned structure) and stops at its window end, restores both participants,
    checkpoints and finalises this loop, which needs the structure alive. Dying at once, as
    the default action does, took the job down (``mpirun`` kills the other ranks) with no final
    checkpoint and the results left "running"."""
    t = open_transport(config.transport, "structure")
    with t, deferred_signals(log):
        return serve(structure, t)


@contextlib.contextmanager
def deferred_signals(
    log: Callable[[str], None] | None = None,
    signums: tuple[int, ...] = (signal.SIGTERM, signal.SIGINT),
) -> Iterator[list[str]]:
    """Within the block, the first of ``signums`` is only noted (in the yielded list, and by
    ``log``, default stderr) and the block goes on; a second one restores the previous handlers
    and is delivered again, so a repeated Ctrl-C or kill still ends a stuck process. Outside
    the main thread (where signals cannot be handled) nothing changes."""
    log = log or (lambda msg: print(msg, file=sys.stderr, flush=True))
    received: list[str] = []
    if threading.current_thread() is not threading.main_thread():
        yield received
        return
    old = {s: signal.getsignal(s) for s in signums}

    def restore() -> None:
        for s, h in old.items():
            signal.signal(s, h)

    def on_signal(signum, frame) -> None:  # noqa: ARG001
        name = signal.Signals(signum).name
        received.append(name)
        if len(received) == 1:
            log(
                f"structure participant: {name} received; serving on until the fluid "
                "participant, which stops at the end of its window, finalises (send it again "
                "to stop at once)"
            )
            return
        restore()
        signal.raise_signal(signum)

    for s in signums:
        signal.signal(s, on_signal)
    try:
        yield received
    finally:
        restore()


def spawn_structure(argv: Sequence[str], module: str | None = None) -> subprocess.Popen:
    """Start this program again as the structure participant (``--participant structure``
    appended to ``argv``); ``module`` runs ``python -m module`` instead of ``argv[0]``.

    Unless a coupling token is given (``MPSFEM_COUPLING_TOKEN`` or ``..._FILE``), this run gets a
    fresh random one, set in this process's environment (its fluid side) and passed to the child
    in its environment (never on a command line, which other users can list): the two processes
    of this run accept only each other, and a second run on the same endpoint is told at once."""
    if not os.environ.get(TOKEN_ENV) and not os.environ.get(TOKEN_FILE_ENV):
        os.environ[TOKEN_ENV] = new_run_token()
    cmd = [sys.executable, "-m", module, *argv] if module else [*argv]
    child = subprocess.Popen([*cmd, "--participant", "structure"], env=dict(os.environ))
    _spawned.append(child)
    return child
