"""The run loops: output cadence, checkpoints, failure handling.

:func:`run_fluid` steps the MPS fluid alone; :func:`run_coupled` advances a fluid-structure system
window by window through the coupler (roles, transports and launch forms in docs/coupler.md). Both
sample probes, write snapshots, flush the results file on a wall-clock cadence, write checkpoints
at a simulated-time interval and, when anything goes wrong, stop with a message after flushing
results and writing a checkpoint of the last good state.
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

from mpsfem.coupler.coupling_scheme import create_scheme
from mpsfem.coupler.errors import CouplingError, PeerError, PeerLostError
from mpsfem.coupler.launch import connect_structure, participant_role, spawn_structure
from mpsfem.coupler.mapping.shape_function import project
from mpsfem.coupler.participant import InterfaceMesh, as_interface_mesh
from mpsfem.coupler.time_window import TIME_EPS
from mpsfem.fluid_methods import (
    FLUID_PARTICIPANTS,
    FluidMethod,
    create_fluid_participant,
    create_fluid_solver,
)
from mpsfem.fluid_mps.geometry import lattice_notes
from mpsfem.fluid_mps.probes import (
    PROBE_UNITS,
    AttachedPressureLedger,
    attach_pressure_probes,
    probe_unit,
)
from mpsfem.progress import Progress
from mpsfem.results.checkpoint import (
    default_checkpoint_path,
    read_checkpoint,
    read_checkpoint_scenario,
    write_checkpoint,
)
from mpsfem.results.results_file import ResultsFile
from mpsfem.results.xdmf import xdmf_path
from mpsfem.sampling import next_due, take_sample
from mpsfem.scenario.compare import (
    ABSENT,
    RESTART_FREE_TEXT,
    at_schema_default,
    restart_differences,
)
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
    """(unit, component names) of a probe's series (N/m and J/m in 2D)."""
    _, comps = PROBE_UNITS[probe.kind]
    if probe.kind in ("force", "displacement"):
        comps = comps[:dim]
    return probe_unit(probe.kind, dim), comps


def check_restart_scenario(
    loaded: LoadedScenario, restart: Path, log: Callable[[str], None]
) -> None:
    """Refuse (ValueError) to continue ``restart`` under other physics or numerics than it ran.

    Only the keys of :data:`mpsfem.scenario.compare.RESTART_FREE_KEYS` (run control, output,
    sampling, transport, convergence controls) may differ. A checkpoint from before the resolved
    scenario was stored is compared by its TOML text (its overrides are unknown): a different
    text is accepted with a warning."""
    resolved, text, _ = read_checkpoint_scenario(restart)
    if resolved is None:
        if text != loaded.text:
            log(
                f"warning: {restart} predates storing the resolved scenario and its scenario "
                "text differs from this one; continuing without checking the physics"
            )
        return
    now = loaded.scenario.model_dump(mode="json")
    diffs = restart_differences(resolved, now)
    # a checkpoint of an earlier version lacks the keys added since: such a key at its
    # default (which keeps the earlier behaviour; docs/architecture.md) is no difference
    filled = [k for k, a, b in diffs if a == ABSENT and at_schema_default(loaded.scenario, k, b)]
    if filled:
        diffs = [d for d in diffs if d[0] not in filled]
        if not diffs:
            log(
                f"note: {restart} predates the keys {', '.join(filled)}; continuing with their "
                "defaults, which are this run's values"
            )
    if not diffs:
        return
    shown = [f"{k}: checkpoint {a!r}, now {b!r}" for k, a, b in diffs[:12]]
    if len(diffs) > 12:
        shown.append(f"... and {len(diffs) - 12} more")
    raise ValueError(
        f"--restart {restart}: the scenario differs from the one the checkpoint ran (a restart "
        f"may change only {RESTART_FREE_TEXT}):\n  " + "\n  ".join(shown)
    )


class _Terminated(Exception):
    pass


_stop_request: list[str] = []  # set by the signal handler, acted on between steps


def _on_signal(signum, frame):  # noqa: ARG001
    """Note the signal; the run loop stops at the end of the current step or window. (Raising
    here would surface inside whatever numba call is running, as a confusing SystemError.)"""
    _stop_request.append(f"received signal {signal.Signals(signum).name}")


def _check_stop() -> None:
    if _stop_request:
        msg = _stop_request[0]
        _stop_request.clear()
        raise _Terminated(msg)


def log_lattice_notes(fluid, log: Callable[[str], None]) -> None:
    """Say which block and wall faces the particle lattice moves (geometry.lattice_notes)."""
    for note in lattice_notes(fluid):
        log(f"note: {note}")


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
    if restart is not None:
        check_restart_scenario(loaded, restart, log)
    t_end = end_time if end_time is not None else sc.run.end_time
    if restart is None:
        log_lattice_notes(sc.fluid, log)
    solver = create_fluid_solver(sc.fluid, loaded.path.parent if loaded.path else None)
    outs = sc.output
    probes = [
        p for p in sc.probes if p.kind in ("pressure", "wave_gauge", "front", "force", "energy")
    ]
    attached = attach_pressure_probes(probes, solver.patches, solver.pos, solver.kind, solver.l0)
    ledger = AttachedPressureLedger(attached)  # accumulated by every step; solver state
    solver.attach_pressure_ledger(ledger)
    interval = {
        p.name: (p.interval if p.interval is not None else outs.probe_interval) for p in probes
    }
    next_probe = {p.name: 0.0 for p in probes}
    next_snap = 0.0
    last_t: dict[str, float] = {}  # when each series was last sampled in this process
    next_ckpt = outs.checkpoint_interval if outs.checkpoint_interval > 0 else math.inf
    ckpt_path = default_checkpoint_path(out)
    sidecar = xdmf_path(out) if outs.xdmf else None  # rewritten by each flush of the results
    resolved = sc.model_dump(mode="json")

    restart_t = -math.inf
    if restart is not None:
        arrays, meta, _ = read_checkpoint(restart, end_time=t_end)
        solver.restore(arrays["fluid"], meta["fluid"])
        solver.load_preconditioner_arrays(
            arrays.get("fluid_preconditioner", {}), meta.get("fluid_preconditioner")
        )
        next_probe.update(meta["next_probe"])
        next_snap = meta["next_snapshot"]
        next_ckpt = meta["next_checkpoint"]
        results = ResultsFile.open_append(out, truncate_after=solver.t, xdmf=sidecar)
        results.record_restart(restart, solver.t, loaded.overrides)
        log(f"restarted from {restart} at t = {solver.t:.6g} s (step {solver.step_count})")
        restart_t = solver.t
    else:
        results = ResultsFile.create(out, loaded.text, loaded.overrides, resolved, xdmf=sidecar)
    for p in probes:
        unit, comps = _probe_meta(p, solver.dim)
        at = {"attach": p.attach} if p.name in attached else None
        results.add_probe(p.name, p.kind, unit, comps, getattr(p, "position", None), at)
    _declare_budget(results, solver)

    def checkpoint() -> Path:
        pre_arrays, pre_meta = solver.preconditioner_arrays()
        meta = {
            "fluid": solver.meta(),
            "fluid_preconditioner": pre_meta,
            "next_probe": next_probe,
            "next_snapshot": next_snap,
            "next_checkpoint": next_ckpt,
        }
        results.flush()  # the file holds every sample up to the checkpoint before it exists
        # the preconditioner travels with the state: the resumed run solves with the very same
        # one, so it is bit-identical, and writing a checkpoint changes nothing in this run
        arrays = {"fluid": solver.state(), "fluid_preconditioner": pre_arrays}
        return write_checkpoint(
            ckpt_path, arrays, meta, loaded.text, resolved, list(loaded.overrides)
        )

    def sample(force: bool = False) -> list[str]:
        """Take the samples due at the solver's time; with ``force`` all of them (the final
        state), none twice at one time. Returns the results-file paths sampled only because
        of ``force`` (``ResultsFile.mark_end_samples``)."""
        nonlocal next_snap
        t = solver.t
        extra = []
        for p in probes:
            take, off = take_sample(last_t, p.name, t, next_probe[p.name], interval[p.name], force)
            if take:
                val = ledger.sample(p.name, solver.p, t) if p.name in attached else None
                results.append_probe(p.name, t, solver.probe_value(p) if val is None else val)
                next_probe[p.name] = next_due(t, interval[p.name])
                extra += [f"probes/{p.name}"] if off else []
        snap = outs.snapshot_interval
        take, off = (
            take_sample(last_t, "/particles", t, next_snap, snap, force) if snap > 0 else (0, 0)
        )
        if take:
            key = results.write_snapshot(t, solver.pos, solver.vel, solver.p, solver.kind)
            next_snap = next_due(t, snap)
            extra += [f"particles/{key}"] if off else []
        return extra

    bar = Progress(solver.t, t_end, sc.run.progress if progress is None else progress, "fluid")
    last_flush = time.perf_counter()
    good = {k: v.copy() for k, v in solver.state().items()}  # valid even if sample() fails first
    good_meta = solver.meta()
    good_pre = solver.preconditioner_state()
    good_probe = dict(next_probe)  # output schedule of the last good state (updated in place)
    good_snap, good_ckpt = next_snap, next_ckpt
    _stop_request.clear()
    old_handlers = {s: signal.signal(s, _on_signal) for s in (signal.SIGTERM,) if _main_thread()}
    t_wall = time.perf_counter()
    try:
        if restart is None:
            sample()
        while solver.t < t_end - 1e-12:
            for k, v in solver.state().items():
                np.copyto(good[k], v)
            good_meta = solver.meta()
            good_pre = solver.preconditioner_state()  # by reference
            good_probe.update(next_probe)
            good_snap, good_ckpt = next_snap, next_ckpt
            dt = solver.dt_towards(t_end)
            solver.step(dt)
            if solver.budget.full:
                results.append_momentum_budget(
                    solver.t, dt, solver.budget.take(solver.vel, solver.kind)
                )
            sample()
            _check_stop()
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
            results.write_snapshot(
                solver.t, solver.pos, solver.vel, solver.p, solver.kind, failure=str(exc)
            )
        except Exception:  # noqa: BLE001 - the state may be unwritable; the checkpoint matters more
            pass
        for k, v in good.items():
            np.copyto(solver.state()[k], v)
        solver.restore(solver.state(), good_meta, good_pre)
        # the output schedule of the last good state too: the failed step's samples are
        # dropped on restart (truncate_after), so the resumed run must take them again
        next_probe.update(good_probe)
        next_snap, next_ckpt = good_snap, good_ckpt
        saved = _failure_checkpoint(checkpoint, ckpt_path, solver.t)
        _close_failed(results, f"failed: {exc}")
        for s, h in old_handlers.items():
            signal.signal(s, h)
        raise RunFailed(
            f"run stopped at t = {failed_at:.6g} s: {exc}\n"
            f"  results (readable, up to the failure): {out}\n  {saved}"
        ) from exc
    bar.close()
    for s, h in old_handlers.items():
        signal.signal(s, h)
    try:
        if solver.t > restart_t:  # the final state at end_time, whatever the grid
            results.mark_end_samples(solver.t, sample(force=True))
        ckpt = checkpoint()
    except OSError as exc:  # a full disk at the very end: the run's data are on disk
        _close_failed(results, f"failed: {exc}")
        raise RunFailed(
            f"run reached t = {solver.t:.6g} s but its final outputs failed: {exc}\n"
            f"  results (readable, up to the last flush): {out}"
        ) from exc
    results.h5.attrs["steps"] = solver.step_count
    results.h5.attrs["stage_times"] = str(solver.times.as_dict())
    wall = time.perf_counter() - t_wall
    results.close(status="finished")
    return RunSummary(out, ckpt, solver.t, solver.step_count, wall)


def _close_failed(results: ResultsFile, status: str) -> None:
    """Close the results file of a failed run with ``status``; a full disk cannot stop that
    (the file is closed anyway, readable up to its last flush)."""
    try:
        results.close(status=status)
    except OSError:
        pass


def _failure_checkpoint(write: Callable[[], Path], path: Path, t: float) -> str:
    """Write the checkpoint of the last good state after a failure; the line that says where
    it is, or, where that write failed too (a full disk), why and which earlier one stays."""
    try:
        return f"checkpoint of the last good state (t = {t:.6g} s): {write()}"
    except OSError as exc:
        kept = f"the earlier checkpoint {path} stays" if path.is_file() else "none was written"
        return f"no checkpoint of the last good state ({exc}); {kept}"


def _declare_budget(results: ResultsFile, solver: FluidMethod) -> None:
    """``/momentum_budget`` of the results file, when the fluid keeps one."""
    if solver.budget.full:
        unit = "N s/m" if solver.dim == 2 else "N s"
        results.add_momentum_budget(
            solver.budget.names, solver.dim, unit, solver.spec.boundary_force
        )


def _main_thread() -> bool:
    import threading

    return threading.current_thread() is threading.main_thread()


# ====================================================================== coupled runs
#: window-record scalars written to /coupling/ besides time, iterations and residual
TIMING_KEYS = ("fluid", "structure", "mapping", "acceleration")


def coupling_config(scenario, transport: str | None = None):
    """The scenario's ``[coupling]`` section (defaults if absent) with the transport kind
    replaced by ``transport`` (``--transport``); a replaced transport keeps the timeouts."""
    from mpsfem.coupler.transport import TRANSPORTS
    from mpsfem.scenario.coupling import CouplingSection

    cfg = scenario.coupling if scenario.coupling is not None else CouplingSection()
    if transport is None or transport == cfg.transport.kind:
        return cfg
    if transport not in TRANSPORTS:
        raise ValueError(f"--transport {transport!r}: allowed {', '.join(TRANSPORTS)}")
    old = cfg.transport
    params = TRANSPORTS.get(transport).Params(
        kind=transport, timeout_s=old.timeout_s, startup_timeout_s=old.startup_timeout_s
    )
    return cfg.model_copy(update={"transport": params})


def member_nodes(scenario) -> list[tuple[str, slice | None]]:
    """(member name, its slice of the structure's interface points), in scenario order (the
    structure participant concatenates the members' nodes in that order), to check the
    structure's interface against the scenario. Plates get None: their meshes' node counts are
    the structure's business, and the fluid splits plates by their cells. Only rectangular
    plates are laid out in the fluid; a polygonal one is refused here, before any compute."""
    out, start = [], 0
    for m in scenario.structure.members:
        if m.type == "plate":
            if m.shape != "rectangle":
                raise ValueError(
                    f"structure.members {m.name!r}: shape = {m.shape!r}; the fluid lays "
                    'coupled plates as rectangles only (shape = "rectangle")'
                )
            out.append((m.name, None))
            continue
        n = m.elements + 1
        out.append((m.name, slice(start, start + n)))
        start += n
    return out


class DisplacementProbe:
    """Displacement of a structure point (m): the member's linear interpolation of its nodal
    displacements (along a beam segment, bilinear on a plate quad, linear on a triangle) at the
    projection of ``position`` on its reference mid-line / mid-surface (the coupler's
    shape-function projection; the end node beyond a beam's end)."""

    def __init__(self, probe, mesh, nodes: slice) -> None:
        self.probe = probe
        m = as_interface_mesh(mesh)
        cells = {
            k: c[(c >= nodes.start).all(axis=1) & (c < nodes.stop).all(axis=1)]
            for k, c in m.cells.items()
        }
        member = InterfaceMesh(m.points, m.normals, cells)
        x = np.asarray([probe.position], dtype=np.float64)
        _, idx, N, _, _ = project(x, member, math.inf)
        self.nodes, self.N = idx[0], N[0]

    def value(self, displacement: np.ndarray) -> np.ndarray:
        return self.N @ displacement[self.nodes]


def _split_state(state: dict) -> tuple[dict[str, np.ndarray], dict]:
    """Arrays (names with '/' escaped as '|', HDF5 groups otherwise) and JSON numbers."""
    arrays, numbers = {}, {}
    for k, v in state.items():
        if isinstance(v, np.ndarray):
            arrays[k.replace("/", "|")] = v
        elif isinstance(v, np.generic):
            numbers[k] = v.item()
        else:
            numbers[k] = v
    return arrays, numbers


def _join_state(arrays: dict, numbers: dict) -> dict:
    return {**numbers, **{k.replace("|", "/"): v for k, v in arrays.items()}}


def _structure_state(structure) -> dict:
    """Full state of the structure participant, local or remote."""
    get = getattr(structure, "get_state", None)
    return get() if get is not None else structure.checkpoint()


def _load_structure_state(structure, state: dict) -> None:
    put = getattr(structure, "set_state", None)
    if put is not None:
        put(state)
    else:
        structure.restore(state)


def _member_energy(structure, member: str) -> np.ndarray:
    parts = getattr(structure, "energy_parts", None)
    e = parts(member) if parts is not None else structure.energy(member)
    return np.array([float(x) for x in e])


def serve_structure_role(loaded: LoadedScenario, config, log: Callable[[str], None]) -> int:
    """The structure participant's process: build it and answer the fluid's requests until the
    fluid finalises. Returns an exit code (0 done, 1 the fluid was lost or failed)."""
    from mpsfem.coupler.launch import serve_structure
    from mpsfem.structure_fem.participant import StructureParticipant

    sc = loaded.scenario
    structure = StructureParticipant(
        sc.structure, base_dir=loaded.path.parent, fluid_density=sc.fluid.density
    )
    try:
        n = serve_structure(structure, config)
    except CouplingError as exc:
        log(f"structure participant stopped: {type(exc).__name__}: {exc}")
        return 1
    log(f"structure participant finished at t = {structure.time:.6g} s ({n} requests)")
    return 0


def run_coupled(
    loaded: LoadedScenario,
    out: Path,
    end_time: float | None = None,
    restart: Path | None = None,
    progress: bool | None = None,
    log: Callable[[str], None] | None = None,
    transport: str | None = None,
    participant: str | None = None,
    child_argv: list[str] | None = None,
) -> RunSummary | None:
    """Run a coupled fluid-structure scenario to ``end_time`` (default: run.end_time).

    ``transport`` overrides ``[coupling.transport] kind``; ``participant`` ("fluid" or
    "structure") runs one side only (MPMD, zenoh); under ``mpirun -n 2`` without it rank 0 is
    the fluid, rank 1 the structure; with zenoh and no ``participant`` this process starts the
    structure as a child (``python -m mpsfem.cli`` with ``child_argv`` plus
    ``--participant structure``). The fluid's process writes ``out`` and the checkpoints and
    returns a :class:`RunSummary`; the structure's process returns None.
    """
    sc = loaded.scenario
    if sc.fluid is None or sc.structure is None:
        raise ValueError("a coupled run needs a [fluid] and a [structure] section")
    if sc.fluid.method not in FLUID_PARTICIPANTS:
        raise ValueError(
            f"fluid.method = {sc.fluid.method!r} has no coupled participant; coupled runs take "
            f"fluid.method = {' or '.join(repr(m) for m in FLUID_PARTICIPANTS)}"
        )
    log = log or (lambda msg: print(msg, file=sys.stderr, flush=True))
    config = coupling_config(sc, transport)
    members = member_nodes(sc)
    kind = config.transport.kind
    role = participant_role(kind, participant)
    if role == "structure":
        code = serve_structure_role(loaded, config, log)
        if code:
            raise RunFailed("the structure participant stopped early (see the message above)")
        return None
    if restart is not None:
        check_restart_scenario(loaded, restart, log)

    child = None
    remote = link = None
    if kind == "inproc":
        from mpsfem.structure_fem.participant import StructureParticipant

        structure = StructureParticipant(
            sc.structure, base_dir=loaded.path.parent, fluid_density=sc.fluid.density
        )
    else:
        if kind == "zenoh" and participant is None:
            child = spawn_structure(child_argv or [], module="mpsfem.cli")
        remote, link = connect_structure(config)
        structure = remote
    try:
        return _fluid_side(
            loaded, out, config, members, structure, remote, link, end_time, restart, progress, log
        )
    finally:
        if child is not None:
            try:
                child.wait(timeout=30)
            except Exception:  # noqa: BLE001 - a child that outlives the run is stopped
                child.kill()
                child.wait()


def _fluid_side(
    loaded, out, config, members, structure, remote, link, end_time, restart, progress, log
) -> RunSummary:
    """The fluid's process of a coupled run: the scheme, the outputs, the failure handling."""
    sc = loaded.scenario
    outs = sc.output
    t_wall = time.perf_counter()
    t_end = end_time if end_time is not None else sc.run.end_time
    try:
        mesh = structure.interface()
        n_nodes = int(np.asarray(mesh.points).shape[0])
        expected = members[-1][1]
        if expected is not None and expected.stop != n_nodes:
            raise ValueError(
                f"the structure interface has {n_nodes} points, the scenario's members "
                f"{[m for m, _ in members]} give {expected.stop}"
            )
        if restart is None:
            log_lattice_notes(sc.fluid, log)
        fluid = create_fluid_participant(
            sc.fluid, mesh, base_dir=loaded.path.parent, member_names=[m for m, _ in members]
        )
        members = [(f.name, f.nodes) for f in fluid.surface.frames]
        scheme = create_scheme(fluid, structure, config, log=log)
        scheme.initialize()
    except BaseException:
        if remote is not None:
            _end_peer(remote, link, failed=True)
        raise
    solver = fluid.solver
    nodes = {name: np.asarray(mesh.points[sl]) for name, sl in members}
    slices = dict(members)

    fluid_kinds = ("pressure", "wave_gauge", "front", "force", "energy")
    probes = [
        p
        for p in sc.probes
        if p.kind in fluid_kinds and not (p.kind == "energy" and p.target in slices)
    ]
    member_energy = [p for p in sc.probes if p.kind == "energy" and p.target in slices]
    attached = attach_pressure_probes(probes, solver.patches, solver.pos, solver.kind, solver.l0)
    ledger = AttachedPressureLedger(attached)  # per fluid step; in the participant's state
    solver.attach_pressure_ledger(ledger)
    disp = [
        DisplacementProbe(p, mesh, slices[p.target]) for p in sc.probes if p.kind == "displacement"
    ]
    every = list(probes) + member_energy + [d.probe for d in disp]
    interval = {
        p.name: (p.interval if p.interval is not None else outs.probe_interval) for p in every
    }
    next_probe = {p.name: 0.0 for p in every}
    last_t: dict[str, float] = {}  # when each series was last sampled in this process
    rec_interval = (
        sc.structure.record_interval
        if sc.structure.record_interval is not None
        else outs.probe_interval
    )
    sched = {
        "next_snapshot": 0.0,
        "next_checkpoint": outs.checkpoint_interval if outs.checkpoint_interval > 0 else math.inf,
        "next_record": 0.0,
        "work_structure_total": 0.0,
        "work_fluid_total": 0.0,
    }
    ckpt_path = default_checkpoint_path(out)
    sidecar = xdmf_path(out) if outs.xdmf else None  # rewritten by each flush of the results
    resolved = sc.model_dump(mode="json")
    last_ckpt: Path | None = None

    if restart is not None:
        arrays, meta, _ = read_checkpoint(restart, end_time=t_end)
        if meta.get("kind") != "coupled":
            raise ValueError(f"{restart} is not a checkpoint of a coupled run")
        fluid.load_state(_join_state(arrays["fluid"], meta["fluid"]))
        solver.load_preconditioner_arrays(
            arrays.get("fluid_preconditioner", {}), meta.get("fluid_preconditioner")
        )
        _load_structure_state(structure, _join_state(arrays["structure"], meta["structure"]))
        scheme.load_state_dict(_join_state(arrays["scheme"], meta["scheme"]))
        next_probe.update(meta["next_probe"])
        sched.update(meta["schedule"])
        results = ResultsFile.open_append(out, truncate_after=scheme.t, xdmf=sidecar)
        results.record_restart(restart, scheme.t, loaded.overrides)
        last_ckpt = Path(restart)
        log(f"restarted from {restart} at t = {scheme.t:.6g} s (window {scheme.index})")
    else:
        results = ResultsFile.create(out, loaded.text, loaded.overrides, resolved, xdmf=sidecar)
    for p in probes:
        unit, comps = _probe_meta(p, solver.dim)
        at = {"attach": p.attach} if p.name in attached else None
        results.add_probe(p.name, p.kind, unit, comps, getattr(p, "position", None), at)
    for p in member_energy:
        results.add_probe(
            p.name,
            "energy",
            probe_unit("energy", solver.dim),
            ("kinetic", "strain"),
            attrs={"target": p.target},
        )
    for d in disp:
        p = d.probe
        comps = ("ux", "uy", "uz")[: solver.dim]
        results.add_probe(p.name, "displacement", "m", comps, p.position, {"target": p.target})
    for name, xyz in nodes.items():
        results.add_structure(name, xyz)
    _declare_budget(results, solver)
    results.h5.attrs["transport"] = config.transport.kind
    results.h5.attrs["coupling_scheme"] = config.scheme

    def write_ckpt() -> Path:
        f_arr, f_num = _split_state(fluid.state())
        s_arr, s_num = _split_state(_structure_state(structure))
        c_arr, c_num = _split_state(scheme.state_dict())
        pre_arr, pre_num = solver.preconditioner_arrays()
        meta = {
            "kind": "coupled",
            "fluid": f_num,
            "fluid_preconditioner": pre_num,
            "structure": s_num,
            "scheme": c_num,
            "next_probe": next_probe,
            "schedule": sched,
        }
        arrays = {
            "fluid": f_arr,
            "fluid_preconditioner": pre_arr,
            "structure": s_arr,
            "scheme": c_arr,
        }
        results.flush()  # the file holds every sample up to the checkpoint before it exists
        # the pressure preconditioner travels with the state (see run_fluid's checkpoint)
        return write_checkpoint(
            ckpt_path, arrays, meta, loaded.text, resolved, list(loaded.overrides)
        )

    def sample(force: bool = False) -> list[str]:
        """As run_fluid's sample: the samples due at the scheme's time, all with ``force``
        (none twice at one time); returns the paths sampled only because of ``force``."""
        t = scheme.t
        extra = []
        for p in every:
            take, off = take_sample(last_t, p.name, t, next_probe[p.name], interval[p.name], force)
            if not take:
                continue
            if p.kind == "displacement":
                d = next(x for x in disp if x.probe is p)
                val = d.value(scheme.d)
            elif p.kind == "energy" and p.target in slices:
                val = _member_energy(structure, p.target)
            elif p.name in attached:
                val = ledger.sample(p.name, solver.p, t)
            else:
                val = fluid.probe_value(p)
            results.append_probe(p.name, t, val)
            next_probe[p.name] = next_due(t, interval[p.name])
            extra += [f"probes/{p.name}"] if off else []
        take, off = take_sample(last_t, "/structure", t, sched["next_record"], rec_interval, force)
        if take:
            for name, sl in slices.items():
                results.append_structure(name, t, scheme.d[sl])
                extra += [f"structure/{name}"] if off else []
            sched["next_record"] = next_due(t, rec_interval)
        snap = outs.snapshot_interval
        take, off = (
            take_sample(last_t, "/particles", t, sched["next_snapshot"], snap, force)
            if snap > 0
            else (0, 0)
        )
        if take:
            key = results.write_snapshot(t, solver.pos, solver.vel, solver.p, solver.kind)
            sched["next_snapshot"] = next_due(t, snap)
            extra += [f"particles/{key}"] if off else []
        return extra

    def record(rec) -> None:
        sched["work_structure_total"] += rec.work_structure
        sched["work_fluid_total"] += rec.work_fluid
        extra = rec.results_row()
        extra["work_structure_total"] = sched["work_structure_total"]
        extra["energy_imbalance"] = (
            rec.structure_energy - scheme.energy0 - sched["work_structure_total"]
        )
        extra["interface_work_error"] = sched["work_structure_total"] - sched["work_fluid_total"]
        for k in TIMING_KEYS:
            extra[f"wall_{k}"] = rec.timings.get(k, 0.0)
        results.append_coupling(rec.time, rec.iterations, rec.residual, **extra)

    bar = Progress(scheme.t, t_end, sc.run.progress if progress is None else progress, "coupled")
    last_flush = time.perf_counter()
    _stop_request.clear()
    old_handlers = {s: signal.signal(s, _on_signal) for s in (signal.SIGTERM,) if _main_thread()}
    window = scheme.window
    good = scheme.state_dict()
    good_probe, good_sched = dict(next_probe), dict(sched)  # updated in place per window
    t_start = scheme.t
    try:
        if restart is None:
            sample(force=True)
            last_ckpt = write_ckpt()
        while t_end - scheme.t > TIME_EPS * window:
            t_next = scheme.t0 + (scheme.index + 1) * window
            if t_next > t_end - TIME_EPS * window:
                t_next = t_end
            good = scheme.state_dict()
            good_probe.update(next_probe)
            good_sched.update(sched)
            if not scheme.implicit:  # the implicit scheme checkpoints both itself
                fluid.checkpoint()
                structure.checkpoint()
            rec = scheme.advance_window(t_next)
            record(rec)
            if solver.budget.full:
                results.append_momentum_budget(
                    scheme.t, rec.window, solver.budget.take(solver.vel, solver.kind)
                )
            sample()
            _check_stop()
            if scheme.t >= sched["next_checkpoint"] - 1e-12:
                sched["next_checkpoint"] += outs.checkpoint_interval
                last_ckpt = write_ckpt()
            now = time.perf_counter()
            if now - last_flush > outs.flush_interval:
                results.flush()
                last_flush = now
            bar.update(scheme.t, rec.window)
    except (Exception, KeyboardInterrupt, _Terminated) as exc:
        bar.close()
        for s, h in old_handlers.items():
            signal.signal(s, h)
        failed_at = fluid.time
        peer_alive = remote is None or not isinstance(exc, PeerLostError | PeerError)
        try:
            results.write_snapshot(
                failed_at, solver.pos, solver.vel, solver.p, solver.kind, failure=str(exc)
            )
        except Exception:  # noqa: BLE001 - the state may be unwritable; the checkpoint matters more
            pass
        where = "the last checkpoint"
        if peer_alive:
            try:
                fluid.restore()
                structure.restore()
                scheme.load_state_dict(good)
                # and the output schedule of that window: its samples are dropped on restart
                next_probe.update(good_probe)
                sched.update(good_sched)
                last_ckpt = write_ckpt()
                where = "a checkpoint of the last good window"
            except (CouplingError, RuntimeError, OSError) as exc2:
                log(f"no new checkpoint: {type(exc2).__name__}: {exc2}")
                peer_alive = peer_alive and not isinstance(exc2, CouplingError)
        _close_failed(results, f"failed: {type(exc).__name__}: {exc}")
        msg = (
            f"coupled run stopped at t = {failed_at:.6g} s: {type(exc).__name__}: {exc}\n"
            f"  results (readable, up to the failure): {out}\n"
            f"  {where} (t = {scheme.t:.6g} s): {last_ckpt}"
        )
        if remote is not None:
            log(f"error: {msg}")
            _end_peer(remote, link, failed=not peer_alive)
        raise RunFailed(msg) from exc
    bar.close()
    for s, h in old_handlers.items():
        signal.signal(s, h)
    try:
        if scheme.t > t_start:  # the final state at end_time, whatever the grid
            results.mark_end_samples(scheme.t, sample(force=True))
        ckpt = write_ckpt()
    except OSError as exc:  # a full disk at the very end: the run's data are on disk
        _close_failed(results, f"failed: {exc}")
        if remote is not None:
            _end_peer(remote, link, failed=False)
        raise RunFailed(
            f"coupled run reached t = {scheme.t:.6g} s but its final outputs failed: {exc}\n"
            f"  results (readable, up to the last flush): {out}"
        ) from exc
    results.h5.attrs["steps"] = solver.step_count
    results.h5.attrs["windows"] = scheme.index
    results.h5.attrs["stage_times"] = str(solver.times.as_dict())
    results.h5.attrs["fluid_coupling_times"] = str(fluid.times)
    results.h5.attrs["particles"] = solver.n
    results.close(status="finished")
    if remote is not None:
        _end_peer(remote, link, failed=False)
    return RunSummary(out, ckpt, scheme.t, solver.step_count, time.perf_counter() - t_wall)


def _end_peer(remote, link, failed: bool) -> None:
    """Let the structure's process end: ``finalize`` it and close the link, or, after losing it,
    abort the transport (MPI: ends every rank, so nothing waits in MPI_Finalize)."""
    if not failed:
        try:
            remote.finalize()
            link.close()
            return
        except Exception:  # noqa: BLE001 - the peer went away meanwhile
            pass
    link.abort()
