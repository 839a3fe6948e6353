"""Size limits checked before any compute: how big a scene may be on this machine.

A scenario whose particles, neighbour grid, structure elements or structure steps would exhaust
the machine (or run for ever) is refused at validation, naming the keys that set its size. The
estimates are cheap (box volumes / spacing^dim, no particle is generated) and err on the large
side.

Memory limit, in this order: ``run.memory_limit_gib`` where given, else the environment variable
``MPSFEM_MEMORY_LIMIT_GIB``, else half of this machine's physical memory.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from typing import TYPE_CHECKING

from mpsfem.scenario.base import COORDINATE_LIMIT, InvalidValue

if TYPE_CHECKING:
    from mpsfem.scenario.fluid import FluidSection
    from mpsfem.scenario.schema import Scenario

#: environment variable overriding the memory limit, GiB
MEMORY_LIMIT_ENV = "MPSFEM_MEMORY_LIMIT_GIB"
#: default memory limit as a fraction of the machine's physical memory
MEMORY_FRACTION = 0.5
#: bytes per particle of a run (measured 1930 B at 64.8k particles in 2D, benchmarks/; 3D
#: particles have about three times the neighbours)
BYTES_PER_PARTICLE = {2: 2048, 3: 6144}
#: bytes per particle of a δ-SPH run (fluid.method = "delta-sph": explicit, no pressure matrix;
#: RK4 keeps two more copies of the state): measured 783 B in 2D (512 B before the per-pair
#: buffers of the faster kernels), the peak-RSS slope between 68k
#: and 120k particles of a still-water tank, h = 1.3 l0, RK4 (benchmarks/bench_delta_sph_memory.py,
#: benchmarks/results/delta_sph_memory.csv), taken x 1.5 for splashing flows' longer neighbour
#: lists; 3D three times 2D, as for MPS (not measured)
BYTES_PER_PARTICLE_DELTA_SPH = {2: 1175, 3: 3525}
#: bytes per neighbour-grid cell (its start index, int64)
BYTES_PER_CELL = 8
#: bytes per structure element (matrices and their factorisation, generous)
BYTES_PER_ELEMENT = 8192
#: most structure time steps a run may take (end_time / structure.time.dt)
MAX_STRUCTURE_STEPS = 10**8
#: largest Rayleigh coefficient x time step (a1 dt) and coefficient / time step (a2 / dt): beyond
#: it the damping term swamps the Newmark matrix (1e300 made it exactly singular)
MAX_RAYLEIGH_PER_STEP = 1e8

GIB = 1024**3


def machine_memory_bytes() -> float:
    """Physical memory of this machine, bytes (16 GiB where it cannot be read)."""
    try:
        return float(os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES"))
    except (AttributeError, ValueError, OSError):
        return 16.0 * GIB


def memory_limit(scenario_limit_gib: float | None) -> tuple[float, str]:
    """(limit in bytes, where it comes from)."""
    if scenario_limit_gib is not None:
        return scenario_limit_gib * GIB, f"run.memory_limit_gib = {scenario_limit_gib}"
    raw = os.environ.get(MEMORY_LIMIT_ENV)
    if raw is not None:
        try:
            value = float(raw)
        except ValueError:
            value = math.nan
        if not (math.isfinite(value) and value > 0):
            raise InvalidValue(
                "run.memory_limit_gib",
                f"environment variable {MEMORY_LIMIT_ENV} = {raw!r}: must be a number of GiB > 0",
            )
        return value * GIB, f"{MEMORY_LIMIT_ENV} = {raw}"
    total = machine_memory_bytes()
    return (
        MEMORY_FRACTION * total,
        f"{MEMORY_FRACTION:g} of this machine's {total / GIB:.3g} GiB; raise it with "
        f"run.memory_limit_gib or {MEMORY_LIMIT_ENV}",
    )


@dataclass
class Part:
    """One contribution to a scene's size: the key that sets it and its estimated count."""

    key: str
    what: str
    count: float
    bytes_each: float

    @property
    def bytes(self) -> float:
        return self.count * self.bytes_each


def _cells(extent: float, l0: float) -> float:
    """Lattice points along an extent, >= 1."""
    return max(1.0, math.floor(extent / l0) + 1.0)


def kernel_support(fluid: FluidSection) -> float:
    """The largest kernel radius of the fluid's method, in spacings: MPS's largest r_e, δ-SPH's
    Wendland support 2h = 2 smoothing_ratio l0."""
    if fluid.method == "delta-sph":
        return 2.0 * fluid.sph.smoothing_ratio
    k = fluid.kernel
    return max(k.re_density, k.re_gradient, k.re_laplacian, k.re_pressure)


def wall_layers(fluid: FluidSection) -> int:
    """Wall particle layers (pressure layer included): fluid.dummy_layers + 1, else enough to
    fill the method's kernel support (fluid_mps/geometry.py default_dummy_layers; the δ-SPH
    solver lays them the same way for its 2h)."""
    if fluid.dummy_layers:
        return fluid.dummy_layers + 1
    return math.ceil(kernel_support(fluid) - 0.5) + 1


def bytes_per_particle(fluid: FluidSection) -> int:
    """Memory per particle of the fluid's method and dimension, B."""
    table = BYTES_PER_PARTICLE_DELTA_SPH if fluid.method == "delta-sph" else BYTES_PER_PARTICLE
    return table[fluid.dim]


def fluid_parts(fluid: FluidSection, extra: list[list[float]] = ()) -> list[Part]:
    """Estimated particles of each block and wall and the neighbour-grid cells."""
    l0 = fluid.spacing
    max_re = kernel_support(fluid)
    layers = wall_layers(fluid)
    each = bytes_per_particle(fluid)
    parts = []
    for i, b in enumerate(fluid.blocks):
        n = math.prod(_cells(u - lo, l0) for lo, u in zip(b.lower, b.upper, strict=False))
        parts.append(Part(f"fluid.blocks[{i}]", "fluid particles", n, each))
    for i, w in enumerate(fluid.walls):
        ext = [u - lo for lo, u in zip(w.lower, w.upper, strict=False)]
        if w.shape == "tank":
            outer = math.prod(_cells(e, l0) + 2 * layers for e in ext)
            inner = math.prod(max(0.0, _cells(e, l0) - 2.0) for e in ext)
        else:
            outer = math.prod(_cells(e, l0) for e in ext)
            inner = math.prod(max(0.0, _cells(e, l0) - 2.0 * layers) for e in ext)
        parts.append(Part(f"fluid.walls[{i}]", "wall particles", outer - inner, each))
    lo, hi = fluid.domain_box(extra)
    h = (max_re + fluid.neighbours.skin) * l0
    cells = math.prod(max(1.0, math.ceil((b - a) / h)) for a, b in zip(lo, hi, strict=False))
    given = fluid.domain_lower is not None or fluid.domain_upper is not None
    parts.append(
        Part(
            "fluid.domain_lower/domain_upper" if given else "fluid domain (default box)",
            "neighbour-grid cells",
            cells,
            BYTES_PER_CELL,
        )
    )
    return parts


def structure_parts(scenario: Scenario) -> list[Part]:
    """Estimated elements of each structure member (where the scenario fixes their number)."""
    parts = []
    for i, m in enumerate(scenario.structure.members if scenario.structure else []):
        n = getattr(m, "elements", None)
        if n is None:
            divisions = getattr(m, "divisions", None)
            n = math.prod(divisions) * 2 if divisions else None
        if n is None:
            mesh = getattr(m, "mesh_size", None)
            if mesh:
                n = 2.0 * (m.extent / mesh + 1.0) ** 2
        if n is not None:
            key = f"structure.members[{i}]"
            parts.append(Part(key, "structure elements", float(n), BYTES_PER_ELEMENT))
    return parts


def _gib(b: float) -> str:
    return f"{b / GIB:.3g} GiB"


def check_coordinates(scenario: Scenario) -> None:
    """Probe positions and member ends lie within +-COORDINATE_LIMIT m (the fluid's corners are
    bounded by their type, :data:`mpsfem.scenario.base.Point`)."""
    points: list[tuple[str, list[float]]] = []
    for i, p in enumerate(scenario.probes):
        pos = getattr(p, "position", None)
        if pos is not None:
            points.append((f"probes[{i}].position", pos))
    for i, m in enumerate(scenario.structure.members if scenario.structure else []):
        for c in m.corners:
            points.append((f"structure.members[{i}]", c))
    for key, point in points:
        if any(not abs(x) <= COORDINATE_LIMIT for x in point):
            raise InvalidValue(
                key,
                f"every coordinate must lie within +-{COORDINATE_LIMIT:g} m (the scene's "
                "coordinates, in metres)",
                point,
            )


def check_structure_time(scenario: Scenario) -> None:
    """The structure's step count and Rayleigh coefficients stay within what a run can do."""
    st = scenario.structure
    if st is None:
        return
    dt = st.time.dt
    steps = scenario.run.end_time / dt
    if not steps <= MAX_STRUCTURE_STEPS:
        raise InvalidValue(
            "structure.time.dt",
            f"with run.end_time = {scenario.run.end_time} s makes {steps:.3g} steps; at most "
            f"{MAX_STRUCTURE_STEPS:.0e} allowed (dt >= {scenario.run.end_time / MAX_STRUCTURE_STEPS:.3g} s)",
            dt,
        )
    for i, m in enumerate(st.members):
        if not m.rayleigh_a1 * dt <= MAX_RAYLEIGH_PER_STEP:
            raise InvalidValue(
                f"structure.members[{i}].rayleigh_a1",
                f"times structure.time.dt = {dt} must be <= {MAX_RAYLEIGH_PER_STEP:g} (the "
                "damping would swamp the time integrator's matrix)",
                m.rayleigh_a1,
            )
        if not m.rayleigh_a2 / dt <= MAX_RAYLEIGH_PER_STEP:
            raise InvalidValue(
                f"structure.members[{i}].rayleigh_a2",
                f"divided by structure.time.dt = {dt} must be <= {MAX_RAYLEIGH_PER_STEP:g} (the "
                "damping would swamp the time integrator's matrix)",
                m.rayleigh_a2,
            )


def check_size(scenario: Scenario) -> None:
    """The scene's estimated memory fits the limit (:func:`memory_limit`)."""
    parts: list[Part] = []
    if scenario.fluid is not None:
        members = scenario.structure.members if scenario.structure is not None else []
        parts += fluid_parts(scenario.fluid, [c for m in members for c in m.corners])
    parts += structure_parts(scenario)
    total = sum(p.bytes for p in parts)
    limit, source = memory_limit(scenario.run.memory_limit_gib)
    if total <= limit:
        return
    biggest = max(parts, key=lambda p: p.bytes)
    listing = "; ".join(f"{p.key}: ~{p.count:.3g} {p.what} ({_gib(p.bytes)})" for p in parts)
    sizing = "fluid.spacing" if biggest.key.startswith("fluid") else biggest.key
    if scenario.fluid is not None and biggest.key.startswith("fluid"):
        sizing = f"fluid.spacing = {scenario.fluid.spacing} and the extent of {biggest.key}"
    raise InvalidValue(
        biggest.key,
        f"the scene needs an estimated {_gib(total)}, more than the memory limit {_gib(limit)} "
        f"({source}). Its size is set by {sizing}. Estimate: {listing}",
    )


def check_limits(scenario: Scenario) -> None:
    """All the checks of this module, cheapest first."""
    check_coordinates(scenario)
    check_structure_time(scenario)
    check_size(scenario)
