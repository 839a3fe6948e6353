"""The run loop shared by every kind of run: output cadence, checkpoints, failure handling.

A *stepper* advances the physics (the MPS fluid alone here; a coupled system drives the same
loop). The loop samples probes, writes snapshots, flushes the results file on a wall-clock
cadence, writes checkpoints at a simulated-time interval and, when anything goes wrong, stops with
a message after flushing results and writing a checkpoint of the last good state.
"""

from __future__ import annotations

import math
import signal
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from mpsfem.fluid_mps.probes import PROBE_UNITS
from mpsfem.fluid_mps.solver import FluidSolver
from mpsfem.progress import Progress
from mpsfem.results.checkpoint import default_checkpoint_path, read_checkpoint, write_checkpoint
from mpsfem.results.results_file import ResultsFile
from mpsfem.results.xdmf import write_xdmf, xdmf_path
from mpsfem.scenario.loader import LoadedScenario


class RunFailed(RuntimeError):
    """A run stopped on an error; results and a checkpoint were written (paths in the message)."""


@dataclass
class RunSummary:
    results: Path
    checkpoint: Path
    t: float
    steps: int
    wall_time: float


def _probe_meta(probe, dim: int) -> tuple[str, tuple[str, ...]]:
    unit, comps = PROBE_UNITS[probe.kind]
    if probe.kind in ("force", "displacement"):
        comps = comps[:dim]
    return unit, comps


class _Terminated(Exception):
    pass


def _on_signal(signum, frame):  # noqa: ARG001
    raise _Terminated(f"received signal {signal.Signals(signum).name}")


def run_fluid(
    loaded: LoadedScenario,
    out: Path,
    end_time: float | None = None,
    restart: Path | None = None,
    progress: bool | None = None,
    log: Callable[[str], None] | None = None,
) -> RunSummary:
    """Run a fluid-only scenario to ``end_time`` (default: run.end_time), writing ``out``."""
    sc = loaded.scenario
    if sc.fluid is None:
        raise ValueError("the scenario has no [fluid] section")
    log = log or (lambda msg: print(msg, file=sys.stderr))
    t_end = end_time if end_time is not None else sc.run.end_time
    solver = FluidSolver(sc.fluid, loaded.path.parent if loaded.path else None)
    outs = sc.output
    probes = [
        p for p in sc.probes if p.kind in ("pressure", "wave_gauge", "front", "force", "energy")
    ]
    interval = {
        p.name: (p.interval if p.interval is not None else outs.probe_interval) for p in probes
    }
    next_probe = {p.name: 0.0 for p in probes}
    next_snap = 0.0
    next_ckpt = outs.checkpoint_interval if outs.checkpoint_interval > 0 else math.inf
    ckpt_path = default_checkpoint_path(out)

    if restart is not None:
        arrays, meta, _ = read_checkpoint(restart)
        solver.restore(arrays["fluid"], meta["fluid"])
        next_probe.update(meta["next_probe"])
        next_snap = meta["next_snapshot"]
        next_ckpt = meta["next_checkpoint"]
        results = ResultsFile.open_append(out, truncate_after=solver.t)
        log(f"restarted from {restart} at t = {solver.t:.6g} s (step {solver.step_count})")
    else:
        results = ResultsFile.create(out, loaded.text, loaded.overrides, sc.model_dump(mode="json"))
    for p in probes:
        unit, comps = _probe_meta(p, solver.dim)
        results.add_probe(p.name, p.kind, unit, comps, getattr(p, "position", None))

    def checkpoint() -> Path:
        meta = {
            "fluid": solver.meta(),
            "next_probe": next_probe,
            "next_snapshot": next_snap,
            "next_checkpoint": next_ckpt,
        }
        path = write_checkpoint(ckpt_path, {"fluid": solver.state()}, meta, loaded.text)
        # the restarted run starts with a fresh preconditioner; so does this one from here on,
        # which keeps both bit-identical
        solver.pressure.reset()
        return path

    def sample(force: bool = False) -> None:
        nonlocal next_snap
        t = solver.t
        for p in probes:
            if force or t >= next_probe[p.name] - 1e-12:
                results.append_probe(p.name, t, solver.probe_value(p))
                next_probe[p.name] = t + interval[p.name] if interval[p.name] > 0 else t
        if outs.snapshot_interval > 0 and (force or t >= next_snap - 1e-12):
            results.write_snapshot(t, solver.pos, solver.vel, solver.p, solver.kind)
            next_snap = t + outs.snapshot_interval
            if outs.xdmf:
                write_xdmf(results.h5, xdmf_path(out))

    bar = Progress(solver.t, t_end, sc.run.progress if progress is None else progress, "fluid")
    last_flush = time.perf_counter()
    good = {k: np.empty_like(v) for k, v in solver.state().items()}
    good_meta = solver.meta()
    old_handlers = {s: signal.signal(s, _on_signal) for s in (signal.SIGTERM,) if _main_thread()}
    t_wall = time.perf_counter()
    try:
        if restart is None:
            sample()
        while solver.t < t_end - 1e-12:
            for k, v in solver.state().items():
                np.copyto(good[k], v)
            good_meta = solver.meta()
            dt = solver.dt_next
            remaining = t_end - solver.t
            n_left = math.ceil(remaining / dt * (1.0 - 1e-12))
            if n_left <= 2:  # land on t_end in equal steps, never a tiny last one
                dt = remaining / n_left
            solver.step(dt)
            sample()
            if solver.t >= next_ckpt - 1e-12:
                next_ckpt += outs.checkpoint_interval
                checkpoint()
            now = time.perf_counter()
            if now - last_flush > outs.flush_interval:
                results.flush()
                last_flush = now
            bar.update(solver.t, dt)
    except (Exception, KeyboardInterrupt, _Terminated) as exc:
        bar.close()
        failed_at = solver.t
        try:
            results.write_snapshot(solver.t, solver.pos, solver.vel, solver.p, solver.kind)
        except Exception:  # noqa: BLE001 - the state may be unwritable; the checkpoint matters more
            pass
        for k, v in good.items():
            np.copyto(solver.state()[k], v)
        solver.restore(solver.state(), good_meta)
        ckpt = checkpoint()
        results.close(status=f"failed: {exc}")
        for s, h in old_handlers.items():
            signal.signal(s, h)
        raise RunFailed(
            f"run stopped at t = {failed_at:.6g} s: {exc}\n"
            f"  results (readable, up to the failure): {out}\n"
            f"  checkpoint of the last good state (t = {solver.t:.6g} s): {ckpt}"
        ) from exc
    bar.close()
    for s, h in old_handlers.items():
        signal.signal(s, h)
    sample(force=False)
    ckpt = checkpoint()
    results.h5.attrs["steps"] = solver.step_count
    results.h5.attrs["stage_times"] = str(solver.times.as_dict())
    if outs.xdmf and results.n_snapshots:
        write_xdmf(results.h5, xdmf_path(out))
    wall = time.perf_counter() - t_wall
    results.close(status="finished")
    return RunSummary(out, ckpt, solver.t, solver.step_count, wall)


def _main_thread() -> bool:
    import threading

    return threading.current_thread() is threading.main_thread()
