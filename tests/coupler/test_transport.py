"""Transports: bit-exact round trips on inproc, mpi and zenoh; a dead or frozen peer ends the
run within the timeout with a clear message; waiting does not burn a core."""

from __future__ import annotations

import json
import signal
import threading

import numpy as np
import pytest
from conftest import MPIRUN, PY, free_port, mpi_cmd, needs_mpi, reap, run, spawn

from mpsfem.coupler.errors import PeerLostError
from mpsfem.coupler.transport import Message, decode, encode
from mpsfem.coupler.transport.inproc import InprocTransport
from mpsfem.coupler.transport.pingpong import sample_arrays

PINGPONG = ["-m", "mpsfem.coupler.transport.pingpong"]


def same_bits(a: np.ndarray, b: np.ndarray) -> bool:
    le = a.dtype.newbyteorder("<")
    return a.shape == b.shape and np.ascontiguousarray(a).astype(le).tobytes() == b.tobytes()


def test_encode_decode_bit_exact():
    arrays = sample_arrays()
    msg = decode(encode(Message("t", {"dt": 1e-4, "nan": float("nan"), "s": "x"}, arrays)))
    assert msg.tag == "t" and msg.meta["dt"] == 1e-4 and msg.meta["s"] == "x"
    assert np.isnan(msg.meta["nan"])
    for k, a in arrays.items():
        assert same_bits(a, msg.arrays[k]), k
        assert msg.arrays[k].flags.writeable
    with pytest.raises(ValueError, match="magic"):
        decode(b"garbage" * 4)


def test_inproc_round_trip_copies():
    a, b = InprocTransport.pair(timeout_s=5.0)

    def echo():
        b.connect()
        b.send(b.recv())
        b.close()

    th = threading.Thread(target=echo)
    th.start()
    a.connect()
    arrays = sample_arrays()
    sent = {k: v.copy() for k, v in arrays.items()}
    a.send(Message("x", {}, sent))
    sent["forces"][:] = 0.0  # the sender reusing its buffer must not change what was sent
    back = a.recv()
    th.join()
    for k, v in arrays.items():
        assert same_bits(v, back.arrays[k]) or v.dtype.byteorder == ">", k
    a.close()


def test_inproc_silent_peer_times_out():
    a, b = InprocTransport.pair(timeout_s=0.6)
    th = threading.Thread(target=b.connect)
    th.start()
    a.connect()
    th.join()
    b._stop_heartbeats()  # the peer freezes
    with pytest.raises(PeerLostError, match=r"waited .* for the structure participant to answer"):
        a.recv()
    a.abort()
    b.abort()


def test_inproc_closed_peer_is_reported():
    a, b = InprocTransport.pair(timeout_s=5.0)
    th = threading.Thread(target=lambda: (b.connect(), b.close()))
    th.start()
    a.connect()
    th.join()
    with pytest.raises(PeerLostError, match="closed the connection"):
        a.recv()


def check_output(out: str, transport: str) -> dict:
    res = json.loads(out.strip().splitlines()[-1])
    assert res["transport"] == transport
    assert res["bit_exact"] and res["meta_ok"]
    return res


@needs_mpi
def test_mpi_round_trip_bit_exact():
    rc, out, err, wall = run(mpi_cmd(*PINGPONG, "--transport", "mpi", "--sizes", "1000"))
    assert rc == 0, err
    res = check_output(out, "mpi")
    assert res["rtt_s_1000"] < 0.05


@needs_mpi
def test_mpi_mpmd_form():
    cmd = [
        MPIRUN, "-n", "1", PY, *PINGPONG, "--transport", "mpi", "--role", "fluid", ":",
        "-n", "1", PY, *PINGPONG, "--transport", "mpi", "--role", "structure",
    ]  # fmt: skip
    rc, out, err, _ = run(cmd)
    assert rc == 0, err
    check_output(out, "mpi")


@needs_mpi
def test_mpi_same_role_twice_is_an_error():
    cmd = [
        MPIRUN, "-n", "1", PY, *PINGPONG, "--transport", "mpi", "--role", "fluid", ":",
        "-n", "1", PY, *PINGPONG, "--transport", "mpi", "--role", "fluid",
    ]  # fmt: skip
    rc, out, err, wall = run(cmd, timeout=30)
    assert rc != 0 and "expected the structure on the other side" in err and wall < 10


@needs_mpi
def test_mpi_dead_peer_ends_the_run():
    """A rank that exits hard: mpirun tears the job down (its own report) well within 10 s."""
    rc, out, err, wall = run(
        mpi_cmd(*PINGPONG, "--transport", "mpi", "--die-after", "0"), timeout=30
    )
    assert rc != 0 and wall < 10, (rc, wall, err)
    assert "BAD TERMINATION" in out + err or "PeerLostError" in err


@needs_mpi
def test_mpi_frozen_peer_detected_within_timeout():
    rc, out, err, wall = run(
        mpi_cmd(*PINGPONG, "--transport", "mpi", "--freeze", "--timeout", "2"), timeout=30
    )
    assert rc != 0 and wall < 10, (rc, wall, err)
    assert "PeerLostError" in err and "structure participant to answer" in err


@needs_mpi
def test_mpi_wait_does_not_spin():
    rc, out, err, _ = run(mpi_cmd(*PINGPONG, "--transport", "mpi", "--wait", "1"))
    assert rc == 0, err
    res = check_output(out, "mpi")
    assert res["wait_wall_s"] > 0.95
    print(f"\nmpi: CPU while waiting {res['wait_cpu_s'] / res['wait_wall_s']:.1%} of a core")
    assert res["wait_cpu_s"] < 0.1 * res["wait_wall_s"]


def zenoh_pair(*fluid_args, structure_args=(), timeout=30.0):
    ep = f"tcp/127.0.0.1:{free_port()}"
    s = spawn([PY, *PINGPONG, "--transport", "zenoh", "--role", "structure", "--endpoint", ep,
               *structure_args])  # fmt: skip
    try:
        f = run(
            [PY, *PINGPONG, "--transport", "zenoh", "--role", "fluid", "--endpoint", ep,
             *fluid_args], timeout=timeout,
        )  # fmt: skip
    finally:
        if s.poll() is None and "--freeze" in structure_args:
            s.send_signal(signal.SIGKILL)
        srv = reap(s)
    return f, srv


def test_zenoh_round_trip_bit_exact():
    (rc, out, err, wall), srv = zenoh_pair("--sizes", "1000")
    assert rc == 0, err + srv[2]
    check_output(out, "zenoh")
    assert srv[0] == 0, srv[2]


def test_zenoh_dead_peer_detected():
    (rc, out, err, wall), srv = zenoh_pair("--timeout", "10", structure_args=["--die-after", "0"])
    assert rc == 4 and "PeerLostError" in err and "has gone" in err, err
    assert wall < 10


def test_zenoh_frozen_peer_detected_within_timeout():
    (rc, out, err, wall), srv = zenoh_pair(
        "--timeout", "2", "--freeze", structure_args=["--freeze", "--timeout", "2"]
    )
    assert rc == 4 and "PeerLostError" in err, err
    assert wall < 10


def test_zenoh_wait_does_not_spin():
    (rc, out, err, _), srv = zenoh_pair("--wait", "1", structure_args=["--wait", "1"])
    assert rc == 0, err
    res = check_output(out, "zenoh")
    assert res["wait_wall_s"] > 0.95
    print(f"\nzenoh: CPU while waiting {res['wait_cpu_s'] / res['wait_wall_s']:.1%} of a core")
    assert res["wait_cpu_s"] < 0.1 * res["wait_wall_s"]


def test_zenoh_missing_peer_fails_at_startup():
    ep = f"tcp/127.0.0.1:{free_port()}"
    rc, out, err, wall = run(
        [PY, *PINGPONG, "--transport", "zenoh", "--role", "fluid", "--endpoint", ep,
         "--startup-timeout", "1.5"], timeout=30,
    )  # fmt: skip
    assert rc == 4 and "did not appear within 1.5 s" in err and wall < 10


def test_zenoh_endpoint_validated():
    from mpsfem.coupler.transport.zenoh import ZenohTransport

    with pytest.raises(ValueError, match="tcp/<host>:<port>"):
        ZenohTransport("fluid", endpoint="udp/127.0.0.1:1")
