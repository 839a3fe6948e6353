"""Zenoh transport: the end of the peer's session and its last frames.

Zenoh dispatches the end of a liveliness token independently of the data: on loopback the last
put of a closing session came after its token's end in 8 of 40 closes (by 0.1 ms at most). A
receiver that stopped at that end ("has gone") lost the peer's last frames: the structure of
test_two_fluids_starting_together_one_is_coupled_the_other_stops failed (rc 4) instead of reading
the fluid's "stop" (1 of 40 runs under load), and a fluid could lose its "finalize" answer.
"""

from __future__ import annotations

import threading
import time
from types import SimpleNamespace

import pytest

from mpsfem.coupler.errors import PeerLostError
from mpsfem.coupler.transport.auth import FrameSealer
from mpsfem.coupler.transport.base import BYE, Message, encode
from mpsfem.coupler.transport.zenoh import END_GRACE_S, PREFIX, ZenohTransport

TOKEN = "a-test-token-of-enough-length-0001"


def coupled_structure() -> tuple[ZenohTransport, FrameSealer]:
    """A structure end locked onto a fluid session, without a zenoh session (frames go into
    its queue as zenoh's callback puts them)."""
    t = ZenohTransport("structure", endpoint="tcp/127.0.0.1:7447", token=TOKEN)
    t._sealer = FrameSealer(TOKEN, "structure", "fluid")
    fluid = FrameSealer(TOKEN, "fluid", "structure")
    t._peer_nonce, t.connected = fluid.nonce, True
    t._alive.set()
    return t, fluid


def end_of(t: ZenohTransport, fluid: FrameSealer) -> None:
    """The fluid's liveliness token ends (zenoh's DELETE sample)."""
    import zenoh

    key = f"{PREFIX}/alive/fluid/{fluid.nonce.hex()}"
    t._on_liveliness(SimpleNamespace(kind=zenoh.SampleKind.DELETE, key_expr=key))


def later(t: ZenohTransport, frame: bytes, after: float = 0.05) -> None:
    threading.Timer(after, t._q.put, args=(frame,)).start()


def test_frames_after_the_peers_end_are_read_then_it_has_gone():
    t, fluid = coupled_structure()
    end_of(t, fluid)
    later(t, fluid.seal(encode(Message("stop")), to=t._sealer.nonce))
    assert t.recv().tag == "stop"  # protocol 1: PeerLostError "has gone" here
    t0 = time.monotonic()
    with pytest.raises(PeerLostError, match="has gone: its zenoh session ended"):
        t.recv()  # nothing more comes: a crash is still reported, END_GRACE_S after the end
    assert END_GRACE_S - 0.1 < time.monotonic() - t0 < END_GRACE_S + 1.0


def test_a_goodbye_after_the_peers_end_ends_the_wait_at_once():
    t, fluid = coupled_structure()
    end_of(t, fluid)
    later(t, fluid.seal(encode(Message(BYE)), to=t._sealer.nonce))
    t0 = time.monotonic()
    with pytest.raises(PeerLostError, match="closed the connection"):
        t.recv()
    assert time.monotonic() - t0 < 0.5 * END_GRACE_S
