"""Coupler component timings: mapping build/apply, acceleration, transport round trips, and a
mock coupled window on every transport.

    .venv/bin/python benchmarks/bench_coupler_components.py [--repeats R] [--quick]

* mapping: the three mappings on a 2D beam (element length = spacing l0 = 2 mm, particles on
  both faces and the tip, 506 interface particles) and a 3D plate (16 x 10 quads, spacing 7.5 mm,
  both faces, 546 particles): build time (operators from scratch) and apply time (displacement + velocity to the
  fluid, forces to the structure, i.e. one window's mapping work);
* acceleration: one ``compute`` of constant, Aitken and IQN-ILS (10 and 50 columns) on an
  interface vector of 500 and 5000 entries;
* transport: round-trip time and throughput of named float64 arrays (1, 1000, 100000 values)
  for inproc (queue pair, threads), mpi (``mpirun -n 2``) and zenoh (two processes, loopback);
* coupled: the mock added-mass case (mass ratio 3, implicit IQN-ILS, 200 windows) through each
  transport: wall time per window (the mock participants cost ~nothing, so this is the
  coupler's own overhead per window: mapping, acceleration, sub-cycling logic and, for
  mpi/zenoh, the remote calls, which appear in the structure's share).

Prints a table and writes benchmarks/results/coupler_components.csv (median of the repeats).
BLAS runs single-threaded (OPENBLAS_NUM_THREADS=1, set here unless given): on a shared 2-core
machine OpenBLAS threads spin against the other processes and a 500 x 50 QR took 760 ms instead
of 0.6 ms.
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # before numpy: see the docstring

import argparse  # noqa: E402
import csv  # noqa: E402
import json  # noqa: E402
import platform  # noqa: E402
import socket  # noqa: E402
import statistics  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import threading  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "src"))
sys.path.insert(0, str(ROOT / "tests" / "coupler"))

from geometry import beam_2d, plate_3d  # noqa: E402

from mpsfem.coupler.acceleration import ACCELERATIONS  # noqa: E402
from mpsfem.coupler.mapping import MAPPINGS  # noqa: E402
from mpsfem.coupler.transport import Message  # noqa: E402
from mpsfem.coupler.transport.inproc import InprocTransport  # noqa: E402

PY = sys.executable
BIN = Path(PY).parent
MPIRUN = str(BIN / "mpirun")
ENV = dict(os.environ, PYTHONPATH=str(ROOT / "src"), OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1")
ROWS: list[dict] = []


def host() -> str:
    return f"{platform.node()} {platform.machine()}, {os.cpu_count()} cpus"


def add(group, name, size, metric, value, unit):
    ROWS.append(
        {"group": group, "name": name, "size": size, "metric": metric, "value": value, "unit": unit}
    )
    print(f"{group:12} {name:28} {size:>8} {metric:22} {value:12.4g} {unit}")


def median_time(fn, repeats, inner=1):
    out = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        for _ in range(inner):
            fn()
        out.append((time.perf_counter() - t0) / inner)
    return statistics.median(out)


def bench_mappings(repeats):
    l0 = 0.002
    beam = beam_2d(length=0.5, elements=250, spacing=l0, thickness=0.012)
    plate = plate_3d(size=(0.16, 0.1), divisions=(16, 10), spacing=0.0075, thickness=0.015)
    for label, (fluid, structure) in (("beam-2d", beam), ("plate-3d", plate)):
        n = fluid.n_points
        for kind in MAPPINGS:
            cls = MAPPINGS.get(kind)
            kw = {}
            if kind != "shape-function":
                p = structure.points
                h = max(
                    np.linalg.norm(p[c[:, 1]] - p[c[:, 0]], axis=1).max()
                    for c in structure.cells.values()
                )
                kw["radius"] = max(2.1 * fluid_spacing(fluid), 0.75 * h)
            m = cls(cls.Params(kind=kind, **kw))
            build = median_time(lambda m=m, f=fluid, s=structure: m.build(f, s), repeats)
            u = np.random.default_rng(0).standard_normal(structure.points.shape)
            F = np.random.default_rng(1).standard_normal(fluid.points.shape)

            def apply(m=m, u=u, F=F):
                m.to_fluid(u)
                m.to_fluid(u)
                m.to_structure(F)

            t = median_time(apply, repeats, inner=200)
            add("mapping", f"{kind} {label}", n, "build_ms", build * 1e3, "ms")
            add("mapping", f"{kind} {label}", n, "apply_us_per_window", t * 1e6, "us")


def fluid_spacing(fluid):
    from mpsfem.coupler.mapping import point_spacing

    return point_spacing(fluid.points)


def bench_acceleration(repeats):
    rng = np.random.default_rng(2)
    for n in (500, 5000):
        for kind, kw, cols in (
            ("constant", {}, 0),
            ("aitken", {}, 0),
            ("iqn-ils", {"max_columns": 10, "reuse_windows": 100}, 10),
            ("iqn-ils", {"max_columns": 50, "reuse_windows": 100}, 50),
        ):
            cls = ACCELERATIONS.get(kind)
            acc = cls(cls.Params(kind=kind, **kw))
            acc.start_window()
            x = rng.standard_normal(n)
            sec = {"velocity": (rng.standard_normal(n), rng.standard_normal(n))}
            for _ in range(cols + 2):  # fill the columns
                x, _ = acc.compute(x, x + rng.standard_normal(n), sec)
            xt = x + rng.standard_normal(n)

            def step(acc=acc, x=x, xt=xt, sec=sec):
                acc._prev = None  # no new column: time the solve with a full V
                acc.compute(x, xt, sec)

            t = median_time(step, repeats, inner=20)
            name = f"{kind}" + (f" ({cols} columns)" if cols else "")
            add("acceleration", name, n, "compute_us", t * 1e6, "us")


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


SIZES = (1, 1000, 100000)


def bench_transport_inproc(repeats):
    a, b = InprocTransport.pair(timeout_s=10.0)

    def echo():
        b.connect()
        while True:
            m = b.recv()
            if m.tag == "stop":
                break
            b.send(m)
        b.close()

    th = threading.Thread(target=echo, daemon=True)
    th.start()
    a.connect()
    for size in SIZES:
        arr = {"x": np.zeros(size)}

        def rt(arr=arr):
            a.send(Message("x", arrays=arr))
            a.recv()

        t = median_time(rt, repeats, inner=100)
        add("transport", "inproc", size, "rtt_us", t * 1e6, "us")
        add("transport", "inproc", size, "throughput_MBps", 2 * size * 8 / t / 1e6, "MB/s")
    a.send(Message("stop"))
    th.join()


def transport_result(kind, res):
    for size in SIZES:
        t = res[f"rtt_s_{size}"]
        add("transport", kind, size, "rtt_us", t * 1e6, "us")
        add("transport", kind, size, "throughput_MBps", res[f"throughput_MBps_{size}"], "MB/s")


def bench_transport_mpi(reps):
    sizes = [str(s) for s in SIZES]
    cmd = [MPIRUN, "-n", "2", PY, "-m", "mpsfem.coupler.transport.pingpong", "--transport", "mpi",
           "--sizes", *sizes, "--reps", str(reps)]  # fmt: skip
    out = subprocess.run(cmd, capture_output=True, text=True, env=ENV, timeout=300)
    if out.returncode:
        print(out.stderr)
        return
    transport_result("mpi", json.loads(out.stdout.strip().splitlines()[-1]))


def bench_transport_zenoh(reps):
    ep = f"tcp/127.0.0.1:{free_port()}"
    base = [PY, "-m", "mpsfem.coupler.transport.pingpong", "--transport", "zenoh", "--endpoint", ep]
    srv = subprocess.Popen([*base, "--role", "structure"], env=ENV)
    sizes = [str(s) for s in SIZES]
    out = subprocess.run(
        [*base, "--role", "fluid", "--sizes", *sizes, "--reps", str(reps)],
        capture_output=True,
        text=True,
        env=ENV,
        timeout=300,
    )
    srv.wait(timeout=30)
    if out.returncode:
        print(out.stderr)
        return
    transport_result("zenoh", json.loads(out.stdout.strip().splitlines()[-1]))


def bench_coupled(windows=200):
    demo = [PY, "-m", "mpsfem.coupler.demo", "--mass-ratio", "3", "--timing",
            "--end-time", str(windows * 1e-3)]  # fmt: skip
    forms = {
        "inproc": [*demo, "--transport", "inproc"],
        "inproc-thread": [*demo, "--transport", "inproc-thread"],
        "mpi": [MPIRUN, "-n", "2", *demo, "--transport", "mpi"],
        "zenoh": [*demo, "--transport", "zenoh", "--endpoint", f"tcp/127.0.0.1:{free_port()}"],
    }
    for form, cmd in forms.items():
        p = subprocess.run(cmd, capture_output=True, text=True, env=ENV, timeout=300)
        if p.returncode:
            print(p.stderr)
            continue
        res = json.loads(p.stdout.strip().splitlines()[-1])
        name = f"mock mu=3 iqn-ils {form}"
        n = res["windows"]
        add("coupled", name, n, "ms_per_window", res["run_s"] / n * 1e3, "ms")
        add("coupled", name, n, "structure_ms_per_window", res["structure"] / n * 1e3, "ms")
        add("coupled", name, n, "mapping_ms_per_window", res["mapping"] / n * 1e3, "ms")
        add("coupled", name, n, "accel_ms_per_window", res["acceleration"] / n * 1e3, "ms")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=7)
    ap.add_argument("--quick", action="store_true", help="fewer repetitions")
    args = ap.parse_args()
    reps = 3 if args.quick else args.repeats
    print(f"host: {host()}")
    print(f"{'group':12} {'name':28} {'size':>8} {'metric':22} {'value':>12} unit")
    bench_mappings(reps)
    bench_acceleration(reps)
    bench_transport_inproc(reps)
    bench_transport_mpi(100 if args.quick else 300)
    bench_transport_zenoh(100 if args.quick else 300)
    bench_coupled(50 if args.quick else 200)
    out = ROOT / "benchmarks" / "results" / "coupler_components.csv"
    out.parent.mkdir(parents=True, exist_ok=True)
    with out.open("w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=[*ROWS[0].keys(), "host"])
        w.writeheader()
        for r in ROWS:
            w.writerow({**r, "value": f"{r['value']:.6g}", "host": host()})
    print(f"wrote {out.relative_to(ROOT)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
