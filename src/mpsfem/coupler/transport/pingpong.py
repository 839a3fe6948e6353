"""Transport check and benchmark: the fluid end sends arrays, the structure end echoes them.

    mpirun -n 2 python -m mpsfem.coupler.transport.pingpong --transport mpi
    python -m mpsfem.coupler.transport.pingpong --transport zenoh --role structure &
    python -m mpsfem.coupler.transport.pingpong --transport zenoh --role fluid

The fluid end prints one JSON line: whether every echo came back bit-identical, round-trip
latency and throughput. ``--die-after N`` makes the echoing end crash (SIGKILL) after N
messages, ``--freeze`` makes it stop itself (SIGSTOP, heartbeats included) on the first
"ping", ``--wait S`` makes it wait S seconds before answering "ping" (to measure the CPU the
fluid end burns while it waits).
"""

from __future__ import annotations

import argparse
import json
import os
import signal
import sys
import time

import numpy as np

from mpsfem.coupler.errors import PeerLostError
from mpsfem.coupler.transport import TRANSPORTS, Message


def sample_arrays(seed: int = 0) -> dict[str, np.ndarray]:
    """Arrays that catch any conversion: odd values, NaN payloads, signed zeros, big and empty."""
    rng = np.random.default_rng(seed)
    odd = np.array(
        [0.0, -0.0, np.inf, -np.inf, np.nan, 5e-324, np.finfo(float).max, 1 / 3, np.pi],
        dtype=np.float64,
    )
    payload_nan = np.frombuffer(np.uint64(0x7FF8_0000_DEAD_BEEF).tobytes(), dtype=np.float64)
    return {
        "odd": odd,
        "nan_payload": payload_nan.copy(),
        "forces": rng.standard_normal((500, 2)) * 1e3,
        "displacement": rng.standard_normal((120, 3)) * 1e-5,
        "empty": np.zeros((0, 2)),
        "ints": np.arange(7, dtype=np.int32),
        "big_endian": np.arange(5, dtype=">f8"),
    }


def make(kind: str, role: str | None, args) -> object:
    cls = TRANSPORTS.get(kind)
    kw = {"timeout_s": args.timeout, "startup_timeout_s": args.startup_timeout}
    if kind == "zenoh":
        kw["endpoint"] = args.endpoint
    return cls(role, **kw)


def echo(t, die_after: int | None, wait: float, freeze: bool = False) -> None:
    n = 0
    while True:
        msg = t.recv()
        if msg.tag == "stop":
            break
        n += 1
        if die_after is not None and n > die_after:
            os.kill(os.getpid(), signal.SIGKILL)  # a crash: no goodbye, no cleanup
        if freeze and msg.tag == "ping":
            os.kill(os.getpid(), signal.SIGSTOP)
        if wait and msg.tag == "ping":
            time.sleep(wait)
        t.send(msg)
    t.close()


def drive(t, args) -> dict:
    arrays = sample_arrays()
    t.send(Message("data", {"x": 1.0}, arrays))
    back = t.recv()
    exact = set(back.arrays) == set(arrays) and all(
        back.arrays[k].dtype.newbyteorder("=") == arrays[k].dtype.newbyteorder("=")
        and back.arrays[k].shape == arrays[k].shape
        and back.arrays[k].tobytes()
        == np.ascontiguousarray(arrays[k]).astype(arrays[k].dtype.newbyteorder("<")).tobytes()
        for k in arrays
    )
    out = {"transport": t.kind, "bit_exact": bool(exact), "meta_ok": back.meta == {"x": 1.0}}
    if args.wait or args.freeze:
        c0, w0 = time.process_time(), time.perf_counter()
        t.send(Message("ping"))
        t.recv()
        out["wait_wall_s"] = time.perf_counter() - w0
        out["wait_cpu_s"] = time.process_time() - c0
    for size in args.sizes:
        a = {"x": np.zeros(size)}
        t.send(Message("warm", arrays=a))
        t.recv()
        reps = max(3, min(args.reps, int(2e8 // max(size * 8, 1))))
        w0 = time.perf_counter()
        for _ in range(reps):
            t.send(Message("x", arrays=a))
            t.recv()
        dt = (time.perf_counter() - w0) / reps
        out[f"rtt_s_{size}"] = dt
        out[f"throughput_MBps_{size}"] = 2 * size * 8 / dt / 1e6
    t.send(Message("stop"))
    t.close()
    return out


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--transport", required=True, choices=["mpi", "zenoh"])
    p.add_argument("--role", choices=["fluid", "structure"], default=None)
    p.add_argument("--endpoint", default="tcp/127.0.0.1:7447")
    p.add_argument("--timeout", type=float, default=10.0)
    p.add_argument("--startup-timeout", type=float, default=60.0)
    p.add_argument("--die-after", type=int, default=None)
    p.add_argument("--wait", type=float, default=0.0)
    p.add_argument("--freeze", action="store_true")
    p.add_argument("--sizes", type=int, nargs="*", default=[])
    p.add_argument("--reps", type=int, default=200)
    args = p.parse_args(argv)
    t = make(args.transport, args.role, args)
    try:
        t.connect()
        if t.role == "structure":
            echo(t, args.die_after, args.wait, args.freeze)
        else:
            print(json.dumps(drive(t, args)), flush=True)
    except PeerLostError as exc:
        print(f"PeerLostError: {exc}", file=sys.stderr, flush=True)
        t.abort()
        return 4
    return 0


if __name__ == "__main__":
    sys.exit(main())
