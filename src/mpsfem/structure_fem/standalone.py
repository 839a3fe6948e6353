"""Structure-only runs (``mpsfem structure``) and modal analysis (``mpsfem modes``).

:func:`run_structure` integrates the scenario's members under self-weight and the prescribed
``[[structure.loads]]`` from t = 0 to ``run.end_time`` with the same participant that coupled runs
use, and writes the results-file contract:

* ``/structure/<member>/{nodes,time,displacement}``: reference node coordinates and the nodal
  translational displacement (time x nodes x dim, m), every ``structure.record_interval``
  (default ``output.probe_interval``; 0 = every step);
* ``/probes/<name>/{time,value}`` for every ``[[probes]]`` of kind "displacement" whose target is
  a member (attrs kind "displacement", unit "m", components ux, uy[, uz], position; value at the
  member point nearest `position`) and of kind "energy" targeting a member (unit "J/m" in 2D,
  "J" in 3D; components kinetic, strain; attr "meaning" says what they are under the scheme:
  the state at the end of each step, under HHT not at the alpha point), every ``interval`` (default ``output.probe_interval``;
  0 = every step).

Records are taken every ``max(1, round(interval / dt))`` steps, at t = 0 and at the end.
"""

from __future__ import annotations

import math
import sys
import time as _time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .modal import ModalResult, format_modes, natural_modes
from .model import build_member
from .participant import StructureParticipant

__all__ = ["StructureRunSummary", "run_structure", "modal_analysis", "cli_main"]

DISPLACEMENT_COMPONENTS = ("ux", "uy", "uz")
#: printed under ``mpsfem modes``: what the frequencies are (and are not)
DRY_MODES_NOTE = (
    "dry (in vacuo) frequencies: the structure alone, without the fluid's added mass; a wetted "
    "member vibrates at lower frequencies"
)


@dataclass
class StructureRunSummary:
    """Outcome of :func:`run_structure`."""

    results: Path
    t: float
    steps: int
    wall_time: float
    factorizations: int


class _ProbeBuffer:
    """Probe samples kept in memory between flushes and appended in blocks (one HDF5 resize per
    probe and flush instead of one per sample)."""

    def __init__(self, rf) -> None:
        self.rf = rf
        self.rows: dict[str, tuple[list[float], list[np.ndarray]]] = {}
        self.n = 0

    def __len__(self) -> int:
        return self.n

    def add(self, name: str, t: float, value: np.ndarray) -> None:
        ts, vs = self.rows.setdefault(name, ([], []))
        ts.append(t)
        vs.append(np.asarray(value, dtype=np.float64))
        self.n += 1

    def write(self) -> None:
        many = getattr(self.rf, "append_probe_rows", None)
        for name, (ts, vs) in self.rows.items():
            if not ts:
                continue
            if many is not None:
                many(name, np.asarray(ts), np.stack(vs))
            else:
                for t, v in zip(ts, vs, strict=True):
                    self.rf.append_probe(name, t, v)
            ts.clear()
            vs.clear()
        self.n = 0


def energy_meaning(time) -> str:
    """What an energy record means under the scheme of `time` (a StructureTime)."""
    base = (
        "kinetic 1/2 v.M v and strain energy (1/2 u.K u; co-rotational members: the sum of "
        "their elements' local strain energies) of the state at the end of each step"
    )
    if time.scheme == "generalized_alpha" and time.rho_inf < 1.0:
        return (
            f"{base}, not at the generalised-alpha points (rho_inf = {time.rho_inf:g}); their "
            "sum decreases by the scheme's numerical dissipation, not by a physical loss"
        )
    if time.scheme == "hht":
        return (
            f"{base}, not at the HHT point t + (1 + alpha) dt (hht_alpha = {time.hht_alpha:g}); "
            "their sum decreases by the scheme's numerical dissipation, not by a physical loss"
        )
    if time.newmark_gamma > 0.5:
        return f"{base}; newmark_gamma > 1/2 dissipates numerically, their sum decreases"
    return f"{base}; average acceleration keeps their sum for linear undamped members"


def _unpack(scenario):
    """(root scenario, text, overrides, base_dir) from a LoadedScenario or a root Scenario."""
    if hasattr(scenario, "scenario") and hasattr(scenario, "text"):
        root = scenario.scenario
        base = scenario.path.parent if getattr(scenario, "path", None) else None
        return root, scenario.text, list(getattr(scenario, "overrides", [])), base
    return scenario, None, [], None


def _every(interval: float | None, dt: float) -> int:
    if interval is None or interval <= 0:
        return 1
    return max(1, round(interval / dt))


def _last_step(T: float, dt: float, n_steps: int) -> float:
    """The last step to reach T (s) after n_steps - 1 steps of dt: dt where T - (n - 1) dt
    differs from it by round-off only (n_steps = ceil(T / dt - 1e-9) admits 1e-9 dt)."""
    h = T - (n_steps - 1) * dt
    return dt if abs(h - dt) <= 1e-9 * dt else h


def run_structure(
    scenario,
    out_path: str | Path,
    progress: bool = True,
    *,
    end_time: float | None = None,
) -> StructureRunSummary:
    """Run the structure of `scenario` alone under its prescribed loads; write ``out_path``.

    `scenario` is a :class:`~mpsfem.scenario.loader.LoadedScenario` (preferred: its text and
    folder are used) or a root scenario model with ``structure``, ``run``, ``output`` and
    ``probes``. `end_time` overrides ``run.end_time``.
    """
    from mpsfem.results.results_file import ResultsFile

    root, text, overrides, base_dir = _unpack(scenario)
    section = getattr(root, "structure", None)
    if section is None:
        raise ValueError("the scenario has no [structure] section")
    T = float(end_time if end_time is not None else root.run.end_time)
    if not T > 0:
        raise ValueError(f"end time {T}: must be > 0")
    members = {m.name for m in section.members}
    probes = [p for p in getattr(root, "probes", []) if p.kind == "displacement"]
    energy_probes = [
        p for p in getattr(root, "probes", []) if p.kind == "energy" and p.target in members
    ]
    part = StructureParticipant(section, prescribed_loads=True, base_dir=base_dir, probes=probes)
    dim = part.dim
    dt = section.time.dt
    n_steps = max(1, math.ceil(T / dt - 1e-9))
    output = getattr(root, "output", None)
    default_interval = getattr(output, "probe_interval", 0.0)
    flush_interval = getattr(output, "flush_interval", 5.0)
    rec_every = _every(
        section.record_interval if section.record_interval is not None else default_interval, dt
    )
    probe_every = {
        p.name: _every(p.interval if p.interval is not None else default_interval, dt)
        for p in probes + energy_probes
    }
    if text is None:
        text = root.model_dump_json(indent=2) if hasattr(root, "model_dump_json") else ""
    resolved = root.model_dump(mode="json") if hasattr(root, "model_dump") else {}
    out_path = Path(out_path)
    t_wall = _time.perf_counter()

    rf = ResultsFile.create(out_path, text, overrides, scenario_resolved=resolved)
    try:
        nodes = part.member_nodes()
        for name, xyz in nodes.items():
            rf.add_structure(name, xyz)
        comps = DISPLACEMENT_COMPONENTS[:dim]
        for p in probes:
            rf.add_probe(p.name, "displacement", "m", comps, p.position, attrs={"target": p.target})
        meaning = energy_meaning(section.time)
        for p in energy_probes:
            unit = "J/m" if dim == 2 else "J"  # 2D: per metre of width, like every 2D energy
            rf.add_probe(
                p.name,
                "energy",
                unit,
                ("kinetic", "strain"),
                attrs={"target": p.target, "meaning": meaning},
            )

        buffer = _ProbeBuffer(rf)

        def record(step: int, t: float, force: bool) -> None:
            if force or step % rec_every == 0:
                for name, d in part.member_displacements().items():
                    rf.append_structure(name, t, d)
            due = [p for p in probes if force or step % probe_every[p.name] == 0]
            if due:
                vals = part.probe_values()
                for p in due:
                    buffer.add(p.name, t, vals[p.name])
            for p in energy_probes:
                if force or step % probe_every[p.name] == 0:
                    buffer.add(p.name, t, np.array(part.energy(p.target)))

        record(0, 0.0, True)
        bar = None
        if progress:
            try:
                from tqdm import tqdm

                bar = tqdm(total=n_steps, unit="step", desc="structure", disable=None)
            except ImportError:  # pragma: no cover
                bar = None
        last_flush = _time.perf_counter()
        t = 0.0
        for k in range(1, n_steps + 1):
            # every step is dt exactly, the last one what is left to T (dt itself when that is
            # dt up to the round-off of T - (n - 1) dt, ~n eps dt: no new factorisation)
            h = dt if k < n_steps else _last_step(T, dt, n_steps)
            part.advance(h)
            t = T if k == n_steps else k * dt
            record(k, t, k == n_steps)
            if bar is not None:
                bar.update(1)
            now = _time.perf_counter()
            if now - last_flush > flush_interval or len(buffer) > 100_000:
                buffer.write()
                rf.flush()
                last_flush = now
        buffer.write()
        if bar is not None:
            bar.close()
    except BaseException as exc:
        try:
            buffer.write()
        finally:
            rf.close(f"failed: {exc}")
        raise
    rf.close("finished")
    return StructureRunSummary(
        results=out_path,
        t=t,
        steps=n_steps,
        wall_time=_time.perf_counter() - t_wall,
        factorizations=part.integrator.factorizations,
    )


def modal_analysis(scenario, n_modes: int = 6) -> dict[str, ModalResult]:
    """Lowest `n_modes` natural modes of every structure member.

    `scenario`: a LoadedScenario, a root scenario or a ``[structure]`` section. Returns member
    name -> :class:`~mpsfem.structure_fem.modal.ModalResult` (``frequency`` in Hz, ``omega`` in
    rad/s, ``damping_ratio`` from the member's Rayleigh coefficients, ``kind``, mode shapes).
    """
    root, *_ = _unpack(scenario)
    section = getattr(root, "structure", root)
    if section is None:
        raise ValueError("the scenario has no [structure] section")
    return {cfg.name: natural_modes(build_member(cfg), n_modes) for cfg in section.members}


def cli_main(args) -> int:
    """Entry for ``mpsfem structure`` / ``mpsfem modes`` (argparse namespace of mpsfem.cli)."""
    from mpsfem.scenario.loader import load_scenario

    loaded = load_scenario(args.scenario, getattr(args, "overrides", []))
    if getattr(loaded.scenario, "structure", None) is None:
        print(f"error: {args.scenario} has no [structure] section", file=sys.stderr)
        return 2
    try:
        if args.command == "modes":
            print(format_modes(modal_analysis(loaded, getattr(args, "count", 6))))
            print(f"note: {DRY_MODES_NOTE}", file=sys.stderr)
            return 0
        out = getattr(args, "out", None) or Path.cwd() / f"{loaded.stem}.h5"
        summary = run_structure(loaded, out, progress=not getattr(args, "no_progress", False))
    except (ValueError, FileNotFoundError) as exc:  # a model that cannot be built or solved
        print(f"error: {exc}", file=sys.stderr)
        return 2
    except FloatingPointError as exc:  # the run diverged; run_structure closed the results
        print(
            f"error: structure run stopped: {exc}; results (readable, up to the failure): {out}",
            file=sys.stderr,
        )
        return 1
    print(
        f"finished t = {summary.t:.6g} s in {summary.steps} steps, {summary.wall_time:.2f} s wall; "
        f"results {summary.results}"
    )
    return 0
