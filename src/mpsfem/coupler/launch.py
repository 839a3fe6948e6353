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

import os
import subprocess
import sys
from collections.abc import Sequence

from mpsfem.coupler.remote import RemoteParticipant, serve
from mpsfem.coupler.transport import Transport, open_transport

__all__ = ["connect_structure", "participant_role", "serve_structure", "spawn_structure"]


def participant_role(kind: str, participant: str | None) -> str | None:
    """This process's role: "fluid", "structure", or None for inproc (both) and for mpi without
    ``--participant`` (taken from the rank when the transport opens)."""
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


def connect_structure(config) -> tuple[RemoteParticipant, Transport]:
    """Fluid side: open ``config.transport`` and return the structure as a remote participant."""
    t = open_transport(config.transport, "fluid")
    return RemoteParticipant(t), t


def serve_structure(structure, config) -> int:
    """Structure side: open the transport, answer the fluid's requests until it finalises."""
    t = open_transport(config.transport, "structure")
    with t:
        return serve(structure, t)


def spawn_structure(argv: Sequence[str], module: str | None = None) -> subprocess.Popen:
    """Start this program again as the structure participant (``--participant structure``
    appended to ``argv``); ``module`` runs ``python -m module`` instead of ``argv[0]``."""
    cmd = [sys.executable, "-m", module, *argv] if module else [*argv]
    return subprocess.Popen([*cmd, "--participant", "structure"], env=dict(os.environ))
