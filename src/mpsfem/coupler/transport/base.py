"""Transport base: messages of named numpy arrays, heartbeats, timeouts, a non-spinning wait.

A :class:`Message` is a tag, a small JSON-able ``meta`` dict and named arrays. On the wire
(MPI, Zenoh) it is one byte string::

    b"MPSFEMC1" | uint64 LE header length | header JSON | raw array bytes, in header order

with the header ``{"tag", "meta", "arrays": [[name, dtype, shape], ...]}`` and every array in
little-endian C order, so float64 data arrive bit for bit (NaN payloads included) and the same
scenario gives bit-identical results on every transport.

Liveness: once connected, a daemon thread sends a heartbeat every ``timeout_s / 4``; the receiver
counts any message as a sign of life and raises :class:`~mpsfem.coupler.errors.PeerLostError`
after ``timeout_s`` without one (a dead or frozen peer), or when both sides have waited on each
other for ``timeout_s`` (a protocol deadlock: heartbeats say whether the sender is waiting). The
first exchange (the handshake) may take up to ``startup_timeout_s``: the peer may still be
building its particles or compiling. Waiting never spins: queue-based transports block on a
condition variable, MPI polls ``Iprobe`` with sleeps growing from 50 us to 2 ms.
"""

from __future__ import annotations

import json
import struct
import threading
import time
from abc import ABC, abstractmethod
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np
from pydantic import Field

from mpsfem.coupler.errors import PeerLostError
from mpsfem.scenario.base import Section

__all__ = ["ROLES", "Message", "Transport", "TransportParams", "decode", "encode", "other_role"]

ROLES = ("fluid", "structure")
MAGIC = b"MPSFEMC1"
#: 2: the listening zenoh end answers the first hello (claim) instead of saying hello first
PROTOCOL = 2
HEARTBEAT = "__hb__"
HELLO = "__hello__"
BYE = "__bye__"


class TransportParams(Section):
    """Settings every transport has."""

    timeout_s: float = Field(
        10.0,
        gt=0,
        description=(
            "Seconds without any message (data or heartbeat) from the other participant after "
            "which the run stops with PeerLostError (> 0)."
        ),
    )
    startup_timeout_s: float = Field(
        120.0,
        gt=0,
        description=(
            "Seconds to wait for the other participant to appear at the start (it may still be "
            "building its particles or compiling) (> 0)."
        ),
    )


def other_role(role: str) -> str:
    if role not in ROLES:
        raise ValueError(f"participant role {role!r}; allowed: {', '.join(ROLES)}")
    return ROLES[1 - ROLES.index(role)]


@dataclass
class Message:
    """A tag, small metadata (JSON types) and named arrays."""

    tag: str
    meta: dict[str, Any] = field(default_factory=dict)
    arrays: dict[str, np.ndarray] = field(default_factory=dict)


def _le(a: np.ndarray) -> np.ndarray:
    a = np.asarray(a)
    if a.dtype.hasobject:
        raise TypeError("object arrays cannot be sent")
    if a.dtype.byteorder == ">":
        a = a.astype(a.dtype.newbyteorder("<"))
    return np.ascontiguousarray(a)


def encode(msg: Message) -> bytes:
    """Serialise a message (see the module docstring for the layout)."""
    arrays = [(k, _le(v)) for k, v in msg.arrays.items()]
    header = {
        "tag": msg.tag,
        "meta": msg.meta,
        "arrays": [[k, a.dtype.str, list(a.shape)] for k, a in arrays],
    }
    hb = json.dumps(header, separators=(",", ":"), allow_nan=True).encode()
    return b"".join([MAGIC, struct.pack("<Q", len(hb)), hb] + [a.tobytes() for _, a in arrays])


def decode(buf: bytes | bytearray | memoryview) -> Message:
    """Inverse of :func:`encode`; arrays are fresh writable copies. A message that is not one
    (bad magic, a header that is no JSON table, arrays of non-numeric types or running past the
    end of the buffer) raises ValueError before anything is allocated for it."""
    mv = memoryview(buf)
    if len(mv) < 16 or bytes(mv[:8]) != MAGIC:
        raise ValueError("not an mpsfem coupler message (bad magic bytes)")
    (n,) = struct.unpack("<Q", mv[8:16])
    if n > len(mv) - 16:
        raise ValueError("coupler message: header longer than the message")
    try:
        header = json.loads(bytes(mv[16 : 16 + n]))
        tag, meta, specs = header["tag"], header["meta"], header["arrays"]
    except (ValueError, KeyError, TypeError, RecursionError) as exc:
        raise ValueError(f"coupler message: bad header ({exc})") from None
    if not (isinstance(tag, str) and isinstance(meta, dict) and isinstance(specs, list)):
        raise ValueError("coupler message: bad header (tag, meta, arrays)")
    off = 16 + n
    arrays = {}
    for spec in specs:
        try:
            name, dt, shape = spec
            dtype = np.dtype(dt)
            shape = tuple(int(k) for k in shape)
        except (ValueError, TypeError) as exc:
            raise ValueError(f"coupler message: bad array entry {spec!r} ({exc})") from None
        if dtype.kind not in "biufc" or any(k < 0 for k in shape):
            raise ValueError(f"coupler message: array {name!r} of {dtype} {shape} refused")
        count = int(np.prod(shape, dtype=np.float64))
        if off + count * dtype.itemsize > len(mv):
            raise ValueError(f"coupler message: array {name!r} runs past the message's end")
        a = np.frombuffer(mv, dtype=dtype, count=count, offset=off).reshape(shape).copy()
        arrays[name] = a
        off += count * dtype.itemsize
    return Message(tag, meta, arrays)


class Transport(ABC):
    """One end of a two-participant link. Subclasses move bytes (or messages)."""

    kind: ClassVar[str]
    #: message transports copy arrays but do not serialise (in-process)
    serialises: ClassVar[bool] = True

    def __init__(
        self, role: str, *, timeout_s: float = 10.0, startup_timeout_s: float = 120.0
    ) -> None:
        self.role = role
        self.peer = other_role(role)
        if not timeout_s > 0 or not startup_timeout_s > 0:
            raise ValueError("timeout_s and startup_timeout_s must be > 0")
        self.timeout_s = float(timeout_s)
        self.startup_timeout_s = float(startup_timeout_s)
        self.connected = False
        self.closed = False
        self._last_seen = time.monotonic()
        self._waiting = False
        self._peer_waiting_since: float | None = None
        self._send_lock = threading.Lock()
        self._hb_stop = threading.Event()
        self._hb_thread: threading.Thread | None = None
        self.stats = {"sent": 0, "received": 0, "bytes_sent": 0, "bytes_received": 0}

    # ------------------------------------------------------------------ subclass hooks
    @abstractmethod
    def _open(self) -> None:
        """Set up the link and wait (up to ``startup_timeout_s``) until the peer is reachable."""

    @abstractmethod
    def _send_bytes(self, data: bytes) -> None: ...

    @abstractmethod
    def _receive_bytes(self, max_wait: float) -> bytes | None:
        """One message if it arrives within ``max_wait`` seconds (without spinning), else None."""

    def _peer_gone(self) -> str | None:
        """A reason if the transport knows the peer is gone (e.g. Zenoh liveliness)."""
        return None

    def _shutdown(self) -> None:  # noqa: B027 - optional hook
        """Release the link."""

    def describe(self) -> str:
        return self.kind

    # message level: serialising transports go through bytes
    def _send_message(self, msg: Message) -> None:
        data = encode(msg)
        self.stats["bytes_sent"] += len(data)
        self._send_bytes(data)

    def _receive_message(self, max_wait: float) -> Message | None:
        data = self._receive_bytes(max_wait)
        if data is None:
            return None
        self.stats["bytes_received"] += len(data)
        try:
            return decode(data)
        except ValueError as exc:
            raise PeerLostError(
                f"{self.describe()}: the {self.peer} participant sent a malformed message ({exc})"
            ) from None

    # ------------------------------------------------------------------ public API
    def connect(self) -> None:
        """Open the link, exchange hellos (roles must differ), start heartbeats. A failure
        releases what was opened (an open Zenoh session kept the process from exiting)."""
        try:
            self._handshake()
        except BaseException:
            self._stop_heartbeats()
            self.closed = True
            self._shutdown()  # not abort(): under MPI that would end the job before its message
            raise
        self.connected = True
        self._hb_thread = threading.Thread(
            target=self._heartbeats, name=f"mpsfem-{self.kind}-heartbeat", daemon=True
        )
        self._hb_thread.start()

    def _chooses_peer(self) -> bool:
        """Whether this end decides who its peer is: it waits for the first hello, then answers
        it (addressed to that session, where the transport addresses frames). The other end
        says hello first and takes the answer as its acknowledgement. False (both say hello at
        once) where the link joins exactly two ends (MPI ranks, in-process queues)."""
        return False

    def _handshake(self) -> None:
        self._open()
        self._last_seen = time.monotonic()
        hello = Message(HELLO, {"role": self.role, "protocol": PROTOCOL})
        if self._chooses_peer():
            # answer before checking: a peer of the wrong role or protocol then says so too
            msg = self._recv(self.startup_timeout_s, expect_hello=True)
            self._send(hello)
        else:
            self._send(hello)
            msg = self._recv(self.startup_timeout_s, expect_hello=True)
        if msg.meta.get("role") != self.peer:
            raise PeerLostError(
                f"{self.describe()}: this process is the {self.role} and expected the "
                f"{self.peer} on the other side, but got {msg.meta.get('role')!r}; give the two "
                "processes different --participant"
            )
        if msg.meta.get("protocol") != PROTOCOL:
            raise PeerLostError(
                f"{self.describe()}: the {self.peer} participant speaks coupling protocol "
                f"{msg.meta.get('protocol')!r}, this one {PROTOCOL}: run the same mpsfem version "
                "on both sides"
            )

    def send(self, msg: Message) -> None:
        """Send a message (arrays are copied or serialised before this returns)."""
        self._require()
        self._send(msg)

    def recv(self) -> Message:
        """Wait for the next message; :class:`PeerLostError` if the peer dies or goes silent."""
        self._require()
        return self._recv(self.timeout_s)

    def close(self) -> None:
        """Say goodbye and release the link (idempotent)."""
        if self.closed:
            return
        self._stop_heartbeats()
        if self.connected:
            try:
                self._send(Message(BYE))
            except Exception:  # noqa: BLE001 - the peer may be gone already
                pass
        self.closed = True
        self._shutdown()

    def abort(self) -> None:
        """Tear down after an error (MPI: abort the whole job so no rank hangs)."""
        self._stop_heartbeats()
        self.closed = True
        self._shutdown()

    def __enter__(self) -> Transport:
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        if exc_type is None:
            self.close()
        else:
            self.abort()

    # ------------------------------------------------------------------ internals
    def _require(self) -> None:
        if self.closed:
            raise PeerLostError(f"{self.describe()}: transport already closed")
        if not self.connected:
            raise RuntimeError("transport used before connect()")

    def _send(self, msg: Message) -> None:
        with self._send_lock:
            self._send_message(msg)
            self.stats["sent"] += 1

    def _recv(self, timeout: float, expect_hello: bool = False) -> Message:
        self._waiting = True
        try:
            wait = min(0.25, timeout / 8.0)
            while True:
                msg = self._receive_message(wait)
                now = time.monotonic()
                if msg is not None:
                    self._last_seen = now
                    if msg.tag == HEARTBEAT:
                        if msg.meta.get("waiting"):
                            if self._peer_waiting_since is None:
                                self._peer_waiting_since = now
                        else:
                            self._peer_waiting_since = None
                        continue
                    self._peer_waiting_since = None
                    if msg.tag == HELLO and not expect_hello:
                        continue
                    if msg.tag == BYE:
                        raise PeerLostError(
                            f"{self.describe()}: the {self.peer} participant closed the "
                            "connection while this one still waited for data"
                        )
                    self.stats["received"] += 1
                    return msg
                gone = self._peer_gone()
                if gone is not None:
                    raise PeerLostError(f"{self.describe()}: the {self.peer} participant {gone}")
                silent = now - self._last_seen
                if silent > timeout:
                    what = "to connect" if expect_hello else "to answer"
                    raise PeerLostError(
                        f"{self.describe()}: waited {silent:.1f} s for the {self.peer} "
                        f"participant {what} (timeout {timeout:g} s): it has died, hangs or was "
                        "never started"
                    )
                pw = self._peer_waiting_since
                if pw is not None and now - pw > timeout:
                    raise PeerLostError(
                        f"{self.describe()}: both participants have waited for each other for "
                        f"{now - pw:.1f} s (deadlock in the coupling protocol)"
                    )
        finally:
            self._waiting = False

    def _heartbeats(self) -> None:
        period = self.timeout_s / 4.0
        while not self._hb_stop.wait(period):
            try:
                self._send(Message(HEARTBEAT, {"waiting": self._waiting}))
            except Exception:  # noqa: BLE001 - the receiving side reports the loss
                return

    def _stop_heartbeats(self) -> None:
        self._hb_stop.set()
        t = self._hb_thread
        if t is not None and t is not threading.current_thread():
            t.join(timeout=2.0)
        self._hb_thread = None
