"""A participant in another process: a client proxy and the server loop that drives the real one.

The coupling scheme runs in one process (the fluid's: it maps, accelerates and writes the results
file) and talks to the structure through :class:`RemoteParticipant`, which implements the
participant protocol by messages over a transport. The structure's process runs :func:`serve`,
which executes each request on the real participant and answers. The scheme code is the same
for a local and a remote structure, so every transport gives the same bits.

Requests (tag, meta, arrays) and answers:

================  ======================  ===================================
request           payload                 answer
================  ======================  ===================================
``interface``     —                       arrays points, normals, thickness,
                                          ``cells/<type>``
``write``         name; array ``value``   none (errors come with the next answer)
``read``          name                    array ``value``
``read_many``     names                   one array per name
``advance``       dt                      meta ``dt`` (time advanced), ``max_dt``
                                          (the next one)
``max_dt``        —                       meta ``value``
``checkpoint``    —                       none
``restore``       —                       none
``energy``        —                       meta ``value`` (NaN if not reported)
``energy_parts``  member (or null)        meta ``value``: the parts of
                                          ``energy(member)``
``get_state``     —                       the ``checkpoint()`` dict: arrays as
                                          arrays, numbers as meta (checkpoint
                                          files)
``set_state``     a ``get_state`` answer  none: ``restore(state)`` (restart)
``finalize``      —                       ``done``; the server loop ends
================  ======================  ===================================

If the real participant raises, the server answers ``error`` (type, message, traceback) and
re-raises; the client raises :class:`~mpsfem.coupler.errors.PeerError` with that text.

Round trips are what a remote participant costs (0.1-0.4 ms each on one machine), so
``max_dt()`` returns the value that came with the last ``advance`` answer until a ``restore``,
and the scheme fetches displacement and velocity in one ``read_many``: an implicit iteration
with one structure sub-step costs two round trips.
"""

from __future__ import annotations

import traceback

import numpy as np

from mpsfem.coupler.errors import PeerError
from mpsfem.coupler.participant import InterfaceMesh, as_interface_mesh, energy_of
from mpsfem.coupler.transport.base import Message, Transport

__all__ = ["RemoteParticipant", "serve"]


class RemoteParticipant:
    """The participant on the other end of ``transport`` (protocol of
    :class:`~mpsfem.coupler.participant.Participant`, plus ``read_many``, ``energy`` and
    ``finalize``)."""

    def __init__(self, transport: Transport) -> None:
        self.transport = transport
        self.name = transport.peer
        self._mesh: InterfaceMesh | None = None
        self._max_dt: float | None = None

    def _call(self, op: str, meta=None, arrays=None, reply: bool = True) -> Message | None:
        self.transport.send(Message(op, meta or {}, arrays or {}))
        if not reply:
            return None
        msg = self.transport.recv()
        if msg.tag == "error":
            m = msg.meta
            raise PeerError(
                f"the {self.name} participant failed in {m.get('op')!r}: {m.get('type')}: "
                f"{m.get('message')}\n--- remote traceback ---\n{m.get('traceback', '')}"
            )
        if msg.tag != op:
            raise PeerError(f"the {self.name} participant answered {msg.tag!r} to {op!r}")
        return msg

    def interface(self) -> InterfaceMesh:
        if self._mesh is None:
            a = self._call("interface").arrays
            cells = {k.split("/", 1)[1]: v for k, v in a.items() if k.startswith("cells/")}
            self._mesh = InterfaceMesh(a["points"], a["normals"], cells, a["thickness"])
        return self._mesh

    def write(self, name: str, array: np.ndarray) -> None:
        self._call("write", {"name": name}, {"value": np.asarray(array)}, reply=False)

    def read(self, name: str) -> np.ndarray:
        return self._call("read", {"name": name}).arrays["value"]

    def read_many(self, names) -> dict[str, np.ndarray]:
        """Several outputs in one round trip."""
        return self._call("read_many", {"names": list(names)}).arrays

    def advance(self, dt: float) -> float:
        meta = self._call("advance", {"dt": float(dt)}).meta
        self._max_dt = float(meta["max_dt"])
        return float(meta["dt"])

    def max_dt(self) -> float:
        if self._max_dt is None:
            self._max_dt = float(self._call("max_dt").meta["value"])
        return self._max_dt

    def checkpoint(self) -> None:
        self._call("checkpoint", reply=False)

    def restore(self) -> None:
        self._max_dt = None
        self._call("restore", reply=False)

    def energy(self) -> float:
        return float(self._call("energy").meta["value"])

    def energy_parts(self, member: str | None = None) -> tuple[float, ...]:
        """The parts of ``energy(member)`` (e.g. kinetic, strain) of the remote participant."""
        return tuple(float(x) for x in self._call("energy_parts", {"member": member}).meta["value"])

    def get_state(self) -> dict:
        """The remote participant's full state (its ``checkpoint()`` dict), for a checkpoint
        file: arrays as arrays, numbers as numbers."""
        msg = self._call("get_state")
        return {**msg.meta, **msg.arrays}

    def set_state(self, state: dict) -> None:
        """Put a state from :meth:`get_state` back (``restore(state)`` on the other side)."""
        arrays = {k: np.asarray(v) for k, v in state.items() if isinstance(v, np.ndarray)}
        meta = {k: v for k, v in state.items() if k not in arrays}
        self._max_dt = None
        self._call("set_state", meta, arrays, reply=False)

    def finalize(self) -> None:
        """End the server loop on the other side."""
        self._call("finalize")


def serve(participant, transport: Transport) -> int:
    """Answer requests on ``transport`` with ``participant`` until ``finalize``; returns the
    number of requests served. Exceptions are reported to the client, then re-raised."""
    n = 0
    while True:
        msg = transport.recv()
        op, meta = msg.tag, msg.meta
        try:
            out = _handle(participant, op, meta, msg.arrays)
        except Exception as exc:
            transport.send(
                Message(
                    "error",
                    {
                        "op": op,
                        "type": type(exc).__name__,
                        "message": str(exc),
                        "traceback": traceback.format_exc(),
                    },
                )
            )
            raise
        n += 1
        if out is not None:
            transport.send(out)
        if op == "finalize":
            return n


def _handle(p, op: str, meta: dict, arrays: dict) -> Message | None:
    if op == "write":
        p.write(meta["name"], arrays["value"])
        return None
    if op == "read":
        return Message(op, arrays={"value": np.asarray(p.read(meta["name"]), dtype=np.float64)})
    if op == "read_many":
        arrays = {n: np.asarray(p.read(n), dtype=np.float64) for n in meta["names"]}
        return Message(op, arrays=arrays)
    if op == "advance":
        done = float(p.advance(float(meta["dt"])))
        return Message(op, {"dt": done, "max_dt": float(p.max_dt())})
    if op == "max_dt":
        return Message(op, {"value": float(p.max_dt())})
    if op == "checkpoint":
        p.checkpoint()
        return None
    if op == "restore":
        p.restore()
        return None
    if op == "energy":
        return Message(op, {"value": energy_of(p)})
    if op == "energy_parts":
        member = meta.get("member")
        e = p.energy(member) if member is not None else p.energy()
        parts = list(e) if isinstance(e, tuple | list | np.ndarray) else [e]
        return Message(op, {"value": [float(x) for x in parts]})
    if op == "get_state":
        state = p.checkpoint()
        if not isinstance(state, dict):
            raise TypeError(f"{type(p).__name__}.checkpoint() returns no state dict")
        arr = {k: np.asarray(v) for k, v in state.items() if isinstance(v, np.ndarray)}
        num = {k: v for k, v in state.items() if k not in arr}
        return Message(op, num, arr)
    if op == "set_state":
        p.restore({**meta, **arrays})
        return None
    if op == "interface":
        m = as_interface_mesh(p.interface())
        arrays = {"points": m.points, "normals": m.normals, "thickness": m.thickness}
        arrays.update({f"cells/{k}": v for k, v in m.cells.items()})
        return Message(op, arrays=arrays)
    if op == "finalize":
        return Message(op)
    raise ValueError(f"unknown request {op!r}")
