"""Zenoh transport (eclipse-zenoh): two processes, explicit TCP endpoint, no scouting.

The structure listens on ``endpoint`` (e.g. ``tcp/127.0.0.1:7447``), the fluid connects to it
(retrying until the structure is up); multicast scouting and gossip are off, so nothing else on
the network is discovered or joins. Each side publishes on ``mpsfem/coupling/<its role>`` and
subscribes to the other's key; a liveliness token ``mpsfem/coupling/alive/<role>`` tells each
side that the other is there (the first exchange waits until the peer's token is seen and the
publisher matches its subscriber) and, when the peer's session ends — process exit, crash or
lost link — that it is gone, which ends a waiting receive with
:class:`~mpsfem.coupler.errors.PeerLostError` within ``END_GRACE_S`` (1 s): zenoh may deliver
the end of the token before the peer's last frames (its "stop", its answer to "finalize", its
goodbye), so frames keep being read until then and a goodbye ends the wait at once. A frozen
peer is caught by the heartbeat timeout.

Messages are byte strings put reliably with congestion control BLOCK (never dropped). Received
samples go from Zenoh's callback into a queue; the receiver blocks on it (no spinning).

Authentication and run isolation (:mod:`~mpsfem.coupler.transport.auth`, threat model in
docs/coupler.md): the listener admits only links presenting a password derived from the run's
coupling token (zenoh user/password), and every message is sealed with an HMAC keyed by the token,
carrying the sender's random session nonce, its addressee's and a growing sequence number.

Handshake (claim and acknowledgement): several connecting processes can reach one listener (a
second run on the same endpoint, or two fluids started together), so the listener alone decides
who its peer is. The connecting end sends its hello (addressed to anyone) once it sees the
listener; the listener takes the first authentic hello, fixes that session as its peer and answers
with a hello addressed to it. The connecting end's handshake ends only with a hello addressed to
its own session; a frame of the listener addressed to another session (that answer, a heartbeat,
data) means the listener chose someone else, and it stops at once with a message instead of
waiting. (Until protocol 1 the listener said hello to anyone before it had chosen: a fluid that
subscribed after that hello but whose own hello came first was chosen, never learnt it, and the
other fluid took the hello to anyone for itself, so both stopped.) Frames that fail the HMAC, come
from another session or repeat a sequence number are dropped, and a liveliness token of another
session (``alive/<role>/<nonce>``) is not taken for the peer's.

Launch: ``mpsfem run S.toml --transport zenoh --participant structure`` and
``... --participant fluid`` in two shells (any order), or ``mpsfem run S.toml --transport zenoh``
which starts both.
"""

from __future__ import annotations

import atexit
import ipaddress
import json
import os
import queue
import re
import shutil
import struct
import sys
import tempfile
import threading
import time
from collections.abc import Callable
from typing import Literal

from pydantic import Field, field_validator

from mpsfem.coupler.errors import PeerLostError
from mpsfem.coupler.transport.auth import ANYONE, TOKEN_ENV, FrameSealer, coupling_token
from mpsfem.coupler.transport.base import HELLO, MAGIC, Transport, TransportParams

PREFIX = "mpsfem/coupling"
#: the user name of zenoh's user/password link authentication (the password comes from the token)
LINK_USER = "mpsfem"
#: seconds a receiver goes on reading after its peer's liveliness token ends: zenoh dispatches
#: that end independently of the data, and the peer's last frames (its "stop", "finalize" answer
#: or goodbye) came up to 0.1 ms after it in 8 of 40 closes (loopback, zenoh 1.10.2, 2026-11-26)
END_GRACE_S = 1.0
#: seconds the process's exit waits, in all, for zenoh sessions still closing (:func:`_finish_closes`)
EXIT_CLOSE_WAIT_S = 10.0
#: close threads that outlived their moment in :meth:`ZenohTransport._shutdown` and that the exit
#: waits for
_PENDING_CLOSES: list[threading.Thread] = []


def _finish_closes() -> None:
    """At exit, before the interpreter finalises, wait (at most EXIT_CLOSE_WAIT_S in all) for
    the zenoh sessions still closing. A close that ended during finalisation returned from
    zenoh's native thread into a Python that no longer runs threads, and the process aborted
    ("FATAL: exception not rethrown", exit -6) after its error message, seen under a loaded
    machine where the close took over a second."""
    deadline = time.monotonic() + EXIT_CLOSE_WAIT_S
    for th in _PENDING_CLOSES:
        th.join(timeout=max(0.0, deadline - time.monotonic()))


atexit.register(_finish_closes)
ENDPOINT_RE = re.compile(r"^tcp/(\[[0-9a-fA-F:]+\]|[A-Za-z0-9.\-]+):([0-9]{1,5})$")


class ZenohParams(TransportParams):
    """Two processes over Zenoh on an explicit TCP endpoint (no scouting)."""

    kind: Literal["zenoh"] = Field(description='"zenoh".')
    endpoint: str = Field(
        "tcp/127.0.0.1:7447",
        description=(
            "TCP endpoint tcp/<host>:<port> the structure listens on and the fluid connects to; "
            "use a free port per concurrent run."
        ),
    )

    @field_validator("endpoint")
    @classmethod
    def _endpoint(cls, v: str) -> str:
        m = ENDPOINT_RE.match(v)
        if not m or not 0 < int(m.group(2)) < 65536:
            raise ValueError(
                "must be tcp/<host>:<port> with port 1..65535, e.g. tcp/127.0.0.1:7447"
            )
        return v


class ZenohTransport(Transport):
    kind = "zenoh"
    Params = ZenohParams

    def __init__(
        self,
        role: str,
        *,
        endpoint: str = "tcp/127.0.0.1:7447",
        listen: bool | None = None,
        token: str | None = None,
        **kw,
    ) -> None:
        super().__init__(role, **kw)
        if not ENDPOINT_RE.match(endpoint):
            raise ValueError(
                f"zenoh endpoint {endpoint!r}: expected tcp/<host>:<port>, e.g. tcp/127.0.0.1:7447"
            )
        self.endpoint = endpoint
        self.listen = (role == "structure") if listen is None else bool(listen)
        self._q: queue.Queue = queue.Queue()
        self._alive = threading.Event()
        self._lost_at: float | None = None  # when the peer's liveliness token ended
        self.session = None
        self._token = token  # None: coupling_token() when the link opens
        self._sealer: FrameSealer | None = None
        self._peer_nonce: bytes | None = None
        self._peer_seq = 0
        #: frames dropped: failed authentication, another session, replayed
        self.rejected = {"forged": 0, "foreign": 0, "replayed": 0}
        self._warned = False
        #: where set, says why the peer can no longer come (e.g. the structure process this
        #: run started has exited), checked while waiting for it
        self.watch: Callable[[], str | None] | None = None
        self._aborting = False  # abort() with a connected peer: the exit does not wait the close

    @classmethod
    def from_config(cls, role, config) -> ZenohTransport:
        return cls(
            role,
            endpoint=config.endpoint,
            timeout_s=config.timeout_s,
            startup_timeout_s=config.startup_timeout_s,
        )

    def describe(self) -> str:
        how = "listening on" if self.listen else "connected to"
        return f"zenoh transport ({self.role}, {how} {self.endpoint})"

    def _config(self, dictionary: str | None = None):
        """The session's configuration; ``dictionary``: the listener's user/password file."""
        import zenoh

        conf = zenoh.Config()
        conf.insert_json5("mode", '"peer"')
        conf.insert_json5("scouting/multicast/enabled", "false")
        conf.insert_json5("scouting/gossip/enabled", "false")
        lease_ms = int(min(10.0, self.timeout_s) * 1000)
        conf.insert_json5("transport/link/tx/lease", str(lease_ms))
        if self.listen:
            conf.insert_json5("listen/endpoints", json.dumps([self.endpoint]))
        else:
            conf.insert_json5("connect/endpoints", json.dumps([self.endpoint]))
            conf.insert_json5("connect/retry", "{period_init_ms: 50, period_max_ms: 500}")
            conf.insert_json5("listen/endpoints", "[]")  # the fluid opens no port
        auth = {"user": LINK_USER, "password": self._sealer.link_password()}
        if dictionary is not None:
            auth["dictionary_file"] = dictionary
        conf.insert_json5("transport/auth/usrpwd", json.dumps(auth))
        return conf

    def _chooses_peer(self) -> bool:
        """The listener answers the first hello (see the module docstring, handshake)."""
        return self.listen

    def _host(self) -> str:
        m = ENDPOINT_RE.match(self.endpoint)
        return m.group(1).strip("[]") if m else ""

    def _loopback(self) -> bool:
        host = self._host()
        if host == "localhost":
            return True
        try:
            return ipaddress.ip_address(host).is_loopback
        except ValueError:
            return False

    def _say(self, text: str) -> None:
        print(text, file=sys.stderr, flush=True)

    def _open(self) -> None:
        import zenoh

        self._sealer = FrameSealer(self._token or coupling_token(), self.role, self.peer)
        if not self._loopback():
            how = "listens on" if self.listen else "connects to"
            self._say(
                f"warning: the {self.role} participant {how} {self.endpoint}, which is not a "
                "loopback address: other machines can reach it. Messages are authenticated by "
                f"the coupling token ({TOKEN_ENV}) but not encrypted (docs/coupler.md, threat "
                "model)"
            )
        folder = tempfile.mkdtemp(prefix="mpsfem-zenoh-") if self.listen else None  # mode 0700
        try:
            dictionary = None
            if folder is not None:  # who may connect: read at open, removed right after
                dictionary = os.path.join(folder, "users")
                fd = os.open(dictionary, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
                with os.fdopen(fd, "w") as f:
                    f.write(f"{LINK_USER}:{self._sealer.link_password()}\n")
            self.session = s = zenoh.open(self._config(dictionary))
        except Exception as exc:  # noqa: BLE001 - zenoh raises ZError
            what = "listen on" if self.listen else "connect to"
            raise PeerLostError(
                f"{self.describe()}: cannot {what} {self.endpoint}: {exc} (is the port in use by "
                "another run? set coupling.transport.endpoint)"
            ) from exc
        finally:
            if folder is not None:
                shutil.rmtree(folder, ignore_errors=True)
        q = self._q
        self._sub = s.declare_subscriber(
            f"{PREFIX}/{self.peer}", lambda sample: q.put(sample.payload.to_bytes())
        )
        self._pub = s.declare_publisher(
            f"{PREFIX}/{self.role}",
            congestion_control=zenoh.CongestionControl.BLOCK,
            reliability=zenoh.Reliability.RELIABLE,
        )
        self._live_sub = s.liveliness().declare_subscriber(
            f"{PREFIX}/alive/{self.peer}/*", self._on_liveliness, history=True
        )
        self._token = s.liveliness().declare_token(
            f"{PREFIX}/alive/{self.role}/{self._sealer.nonce.hex()}"
        )
        how = "listening on" if self.listen else "connecting to"
        self._say(
            f"{self.role} participant: waiting for the {self.peer} ({how} {self.endpoint}, "
            f"timeout {self.startup_timeout_s:g} s) ..."
        )
        deadline = time.monotonic() + self.startup_timeout_s
        while not (self._alive.is_set() and self._pub.matching_status.matching):
            gone = self.watch() if self.watch is not None else None
            if gone is not None:
                raise PeerLostError(f"{self.describe()}: {gone}")
            if time.monotonic() > deadline:
                raise PeerLostError(
                    f"{self.describe()}: the {self.peer} participant did not appear within "
                    f"{self.startup_timeout_s:g} s (startup_timeout_s); start it with the same "
                    "endpoint and the same coupling token (a participant with another token "
                    f"cannot connect: {TOKEN_ENV}, docs/coupler.md)"
                )
            self._alive.wait(0.01)

    def _on_liveliness(self, sample) -> None:
        import zenoh

        if sample.kind == zenoh.SampleKind.PUT:
            self._alive.set()
        elif sample.kind == zenoh.SampleKind.DELETE and self._alive.is_set():
            # only the end of the peer's own session counts (another run's process may come
            # and go on the same endpoint)
            nonce = str(sample.key_expr).rsplit("/", 1)[-1]
            peer = self._peer_nonce
            if peer is not None and nonce == peer.hex():
                self._lost_at = time.monotonic()
                self._q.put(b"")  # wake a waiting receiver

    def _peer_gone(self) -> str | None:
        lost = self._lost_at
        if lost is not None and time.monotonic() - lost >= END_GRACE_S:
            # frames it sent before its end are read until then (a goodbye ends the wait sooner)
            return "has gone: its zenoh session ended (process exited, crashed or lost the link)"
        if not self.connected and self.watch is not None:
            gone = self.watch()
            if gone is not None:
                return f"will not come: {gone}"
        return None

    def _send_bytes(self, data: bytes) -> None:
        self._pub.put(self._sealer.seal(data, to=self._peer_nonce or ANYONE))

    def _receive_bytes(self, max_wait: float) -> bytes | None:
        deadline = time.monotonic() + max_wait
        while True:
            try:
                frame = self._q.get(timeout=max(0.0, deadline - time.monotonic()))
            except queue.Empty:
                return None
            if not frame:
                return None  # woken by the peer's liveliness ending
            payload = self._accept(frame)
            if payload is not None:
                return payload

    def _accept(self, frame: bytes) -> bytes | None:
        """The payload of a frame of the peer's session, else None (dropped and counted)."""
        opened = self._sealer.open(frame)
        if opened is None:
            self.rejected["forged"] += 1
            if not self.connected:
                raise PeerLostError(
                    f"{self.describe()}: a {self.peer} participant on {self.endpoint} sent a "
                    "message that fails authentication: it belongs to another run (give each "
                    "run its own coupling.transport.endpoint) or was started with another "
                    f"coupling token (the same {TOKEN_ENV} must reach both programs)"
                )
            self._warn("failed authentication (forged, or of another run)")
            return None
        nonce, to, seq, payload = opened
        taken = (
            f"{self.describe()}: the {self.peer} participant on {self.endpoint} is already "
            f"coupled to another {self.role} participant: another run uses this endpoint; give "
            "each concurrent run its own coupling.transport.endpoint"
        )
        if self._peer_nonce is None:
            if _tag_of(payload) != HELLO or to not in (ANYONE, self._sealer.nonce):
                raise PeerLostError(taken)
            self._peer_nonce, self._peer_seq = nonce, seq
            return payload
        if nonce != self._peer_nonce:
            self.rejected["foreign"] += 1
            self._warn(f"came from another {self.peer} participant (another run on this endpoint)")
            return None
        if seq <= self._peer_seq:
            self.rejected["replayed"] += 1
            self._warn("repeated an earlier sequence number (replayed)")
            return None
        if to not in (ANYONE, self._sealer.nonce):
            raise PeerLostError(taken)  # our peer talks to another session: it is not ours
        self._peer_seq = seq
        return payload

    def _warn(self, why: str) -> None:
        if not self._warned:
            self._warned = True
            self._say(
                f"warning: {self.describe()}: dropped a message that {why}; further ones are "
                "dropped silently"
            )

    def _shutdown(self) -> None:
        s, self.session = self.session, None
        if s is None:
            return

        def close() -> None:
            try:
                s.close()
            except Exception:  # noqa: BLE001 - closing after the peer vanished
                pass

        # a graceful close flushes towards the peer and can block ~10 s when the peer is frozen:
        # give it a moment, then leave it to the process exit, which waits for it (bounded)
        # unless this is an abort with a peer that may be frozen
        th = threading.Thread(target=close, name="mpsfem-zenoh-close", daemon=True)
        th.start()
        th.join(timeout=1.0)
        if th.is_alive() and not (self.connected and self._aborting):
            _PENDING_CLOSES.append(th)

    def abort(self) -> None:
        """As :meth:`Transport.abort`; the process's exit does not wait for this session's
        close when it was connected (its peer may be frozen)."""
        self._aborting = True
        super().abort()


def _tag_of(payload: bytes) -> str | None:
    """The tag of an encoded message (its header only), None if it is not one."""
    try:
        if payload[:8] != MAGIC:
            return None
        (n,) = struct.unpack("<Q", payload[8:16])
        if n > len(payload):
            return None
        tag = json.loads(payload[16 : 16 + n]).get("tag")
    except (ValueError, AttributeError, RecursionError, struct.error):
        return None
    return tag if isinstance(tag, str) else None
