"""A coupled run of the mock participants over any transport (tests, benchmarks, examples).

    python -m mpsfem.coupler.demo --transport inproc --out a.npz
    mpirun -n 2 python -m mpsfem.coupler.demo --transport mpi --out b.npz
    mpirun -n 1 python -m mpsfem.coupler.demo --transport mpi --participant fluid --out c.npz : \\
           -n 1 python -m mpsfem.coupler.demo --transport mpi --participant structure
    python -m mpsfem.coupler.demo --transport zenoh --out d.npz      (starts the structure itself)

The fluid process writes the per-window records and the final interface state to ``--out``
(.npz); the same settings give bit-identical files on every transport.
"""

from __future__ import annotations

import argparse
import json
import sys
import threading
import time

import numpy as np

from mpsfem.coupler import mock
from mpsfem.coupler.coupling_scheme import create_scheme
from mpsfem.coupler.errors import CouplingError, PeerLostError
from mpsfem.coupler.launch import (
    connect_structure,
    participant_role,
    serve_structure,
    spawn_structure,
)
from mpsfem.coupler.remote import RemoteParticipant, serve
from mpsfem.coupler.transport.inproc import InprocTransport
from mpsfem.scenario.coupling import CouplingSection


def config_from(args) -> CouplingSection:
    kind = "inproc" if args.transport == "inproc-thread" else args.transport
    transport = {"kind": kind, "timeout_s": args.timeout}
    if kind == "zenoh":
        transport["endpoint"] = args.endpoint
    return CouplingSection.model_validate(
        {
            "scheme": args.scheme,
            "mapping": {"kind": args.mapping},
            "acceleration": {"kind": args.acceleration},
            "transport": transport,
        }
    )


def timed_run(scheme, args) -> None:
    scheme.initialize()
    t0 = time.perf_counter()
    scheme.run(args.end_time)
    if args.timing:
        wall = time.perf_counter() - t0
        n = len(scheme.history)
        parts = {
            k: float(scheme.history.column(k).sum())
            for k in ("fluid", "structure", "mapping", "acceleration")
        }
        print(json.dumps({"windows": n, "run_s": wall, **parts}), flush=True)


def save(path, scheme, fluid) -> None:
    arrays = {f"history/{k}": v for k, v in scheme.history_arrays().items()}
    arrays.update(d=scheme.d, v=scheme.v, F_s=scheme.F_s, F_f=scheme.F_f, fluid_F=fluid.F)
    np.savez(path, **arrays)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument(
        "--transport", default="inproc", choices=["inproc", "inproc-thread", "mpi", "zenoh"]
    )
    p.add_argument("--participant", choices=["fluid", "structure"], default=None)
    p.add_argument("--scheme", default="implicit")
    p.add_argument("--mapping", default="shape-function")
    p.add_argument("--acceleration", default="iqn-ils")
    p.add_argument("--mass-ratio", type=float, default=1.0)
    p.add_argument("--end-time", type=float, default=0.02)
    p.add_argument("--endpoint", default="tcp/127.0.0.1:7447")
    p.add_argument("--timeout", type=float, default=10.0)
    p.add_argument("--out", default=None)
    p.add_argument("--timing", action="store_true", help="print the run's wall time (JSON)")
    args = p.parse_args(argv)
    config = config_from(args)
    fluid, structure = mock.pair(args.mass_ratio)

    if args.transport == "inproc":
        scheme = create_scheme(fluid, structure, config)
        timed_run(scheme, args)
        if args.out:
            save(args.out, scheme, fluid)
        return 0
    if args.transport == "inproc-thread":
        a, b = InprocTransport.pair(timeout_s=args.timeout)
        server = threading.Thread(target=lambda: (b.connect(), serve(structure, b)))
        server.start()
        a.connect()
        scheme = create_scheme(fluid, RemoteParticipant(a), config)
        timed_run(scheme, args)
        scheme.structure.finalize()
        server.join()
        if args.out:
            save(args.out, scheme, fluid)
        return 0

    role = participant_role(config.transport.kind, args.participant)
    child = None
    if config.transport.kind == "zenoh" and args.participant is None:
        child = spawn_structure(sys.argv[1:], module="mpsfem.coupler.demo")
    if role == "structure":
        try:
            serve_structure(structure, config)
        except (PeerLostError, CouplingError) as exc:
            print(f"structure: {type(exc).__name__}: {exc}", file=sys.stderr, flush=True)
            return 4
        return 0
    remote, transport = connect_structure(config)
    try:
        scheme = create_scheme(fluid, remote, config)
        timed_run(scheme, args)
        remote.finalize()
    except CouplingError as exc:
        print(f"fluid: {type(exc).__name__}: {exc}", file=sys.stderr, flush=True)
        transport.abort()
        return 4
    transport.close()
    if args.out:
        save(args.out, scheme, fluid)
    if child is not None:
        child.wait(timeout=30)
    return 0


if __name__ == "__main__":
    sys.exit(main())
