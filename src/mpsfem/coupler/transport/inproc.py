"""In-process transport: two ends joined by queues (copies of the arrays, no serialisation).

A coupled run with ``kind = "inproc"`` does not use a transport at all — the coupling scheme calls
both participants directly. This pair of queue ends is the in-process stand-in for a link: the
remote-participant protocol runs over it with the structure served from a thread (tests, and a
check that a scheme gives the same bits through a link as through direct calls).
"""

from __future__ import annotations

import queue
from typing import Literal

import numpy as np
from pydantic import Field

from mpsfem.coupler.transport.base import Message, Transport, TransportParams


class InprocParams(TransportParams):
    """Both participants in one process, called directly (the default)."""

    kind: Literal["inproc"] = Field(description='"inproc".')


class InprocTransport(Transport):
    kind = "inproc"
    Params = InprocParams
    serialises = False

    def __init__(self, role: str, inbox: queue.Queue, outbox: queue.Queue, **kw) -> None:
        super().__init__(role, **kw)
        self._inbox, self._outbox = inbox, outbox

    @classmethod
    def pair(cls, **kw) -> tuple[InprocTransport, InprocTransport]:
        """(fluid end, structure end) joined to each other; connect both (e.g. in two threads)."""
        a, b = queue.Queue(), queue.Queue()
        return cls("fluid", a, b, **kw), cls("structure", b, a, **kw)

    @classmethod
    def from_config(cls, role, config):  # pragma: no cover - one process has no peer to find
        raise ValueError(
            'transport "inproc" runs both participants in one process; there is no separate '
            "participant to connect to (use mpi or zenoh for --participant runs)"
        )

    def _open(self) -> None:
        pass

    def _send_message(self, msg: Message) -> None:
        arrays = {k: np.array(v, copy=True) for k, v in msg.arrays.items()}
        self._outbox.put(Message(msg.tag, dict(msg.meta), arrays))

    def _receive_message(self, max_wait: float) -> Message | None:
        try:
            return self._inbox.get(timeout=max_wait)
        except queue.Empty:
            return None

    def _send_bytes(self, data: bytes) -> None:  # pragma: no cover - not used
        raise NotImplementedError

    def _receive_bytes(self, max_wait: float) -> bytes | None:  # pragma: no cover - not used
        raise NotImplementedError
