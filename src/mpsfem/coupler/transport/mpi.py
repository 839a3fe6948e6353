"""MPI transport (mpi4py): two ranks, fluid and structure.

Launch forms (rank 0 is the fluid unless ``--participant`` says otherwise):

    mpirun -n 2 mpsfem run S.toml --transport mpi
    mpirun -n 1 mpsfem run S.toml --transport mpi --participant fluid : \\
           -n 1 mpsfem run S.toml --transport mpi --participant structure      (MPMD)

Messages are byte strings (see :mod:`~mpsfem.coupler.transport.base`) sent with ``Isend`` on a
private duplicate of the communicator. MPICH's blocking receive busy-polls and would take a core
the fluid needs, so waiting is ``Iprobe`` polling that yields the core (``sched_yield``) for the
first millisecond — MPICH delivers shared-memory messages only while the receiver polls, and pure
sleeping waits measured 6 ms per round trip instead of 0.04 ms — then sleeps growing from 50 us to
2 ms: 5.5-7.6 % of a core while idle on the 2-core development VM (2026-11-22; with 1 ms sleeps it
had grown from 2.3 % to 7-11 % there, over the test's 10 % bound). A reply that comes after the
first few milliseconds of a wait is picked up at most 2 ms late. Heartbeats come from a second
thread (MPI_THREAD_MULTIPLE, mpi4py's default). A rank killed outright (SIGKILL, segfault) makes
``mpirun`` kill the job within a second with its own "BAD TERMINATION" report; a rank that hangs
is caught by the timeout, and :meth:`MPITransport.abort` then ends every rank (``MPI_Abort``) so
nothing waits forever in ``MPI_Finalize``.
"""

from __future__ import annotations

import os
import sys
import time
from typing import Literal

from pydantic import Field

from mpsfem.coupler.transport.base import ROLES, Transport, TransportParams

TAG = 7100
_SPIN_S, _SLEEP_MIN, _SLEEP_MAX = 1e-3, 5e-5, 2e-3


class MPIParams(TransportParams):
    """Two MPI ranks (mpirun -n 2, or MPMD): rank 0 fluid, rank 1 structure."""

    kind: Literal["mpi"] = Field(description='"mpi".')


class MPITransport(Transport):
    kind = "mpi"
    Params = MPIParams

    def __init__(self, role: str | None = None, *, comm=None, **kw) -> None:
        from mpi4py import MPI

        self._MPI = MPI
        world = comm if comm is not None else MPI.COMM_WORLD
        size = world.Get_size()
        if size != 2:
            raise ValueError(
                f"the mpi transport needs exactly 2 MPI ranks (fluid and structure), got {size}: "
                "launch with 'mpirun -n 2 ...' or the MPMD form '-n 1 ... : -n 1 ...'"
            )
        rank = world.Get_rank()
        super().__init__(role if role is not None else ROLES[rank], **kw)
        self.comm = world.Dup()
        self.rank, self.peer_rank = rank, 1 - rank
        self._pending: list = []
        self._status = MPI.Status()

    @classmethod
    def from_config(cls, role, config) -> MPITransport:
        return cls(role, timeout_s=config.timeout_s, startup_timeout_s=config.startup_timeout_s)

    def describe(self) -> str:
        return f"mpi transport (rank {self.rank}, {self.role})"

    def _open(self) -> None:
        pass

    def _send_bytes(self, data: bytes) -> None:
        MPI = self._MPI
        req = self.comm.Isend([data, MPI.BYTE], dest=self.peer_rank, tag=TAG)
        self._pending.append((req, data))
        self._pending = [(r, d) for r, d in self._pending if not r.Test()]

    def _receive_bytes(self, max_wait: float) -> bytes | None:
        MPI = self._MPI
        start = time.monotonic()
        deadline = start + max_wait
        pause = _SLEEP_MIN
        while True:
            if self.comm.Iprobe(source=self.peer_rank, tag=TAG, status=self._status):
                buf = bytearray(self._status.Get_count(MPI.BYTE))
                self.comm.Recv([buf, MPI.BYTE], source=self.peer_rank, tag=TAG)
                return buf
            now = time.monotonic()
            if now >= deadline:
                return None
            if now - start < _SPIN_S:
                os.sched_yield()
                continue
            time.sleep(min(pause, deadline - now))
            pause = min(2.0 * pause, _SLEEP_MAX)

    def _shutdown(self) -> None:
        deadline = time.monotonic() + 2.0
        with self._send_lock:
            while self._pending and time.monotonic() < deadline:
                self._pending = [(r, d) for r, d in self._pending if not r.Test()]
                time.sleep(1e-3)

    def abort(self, code: int = 1) -> None:
        """End every rank of the job (after an error; flush results first)."""
        self._stop_heartbeats()
        self.closed = True
        sys.stdout.flush()
        sys.stderr.flush()
        self.comm.Abort(code)

    def __exit__(self, exc_type, exc, tb) -> None:
        if exc_type is not None:
            print(f"error ({self.role}): {exc_type.__name__}: {exc}", file=sys.stderr, flush=True)
        super().__exit__(exc_type, exc, tb)
