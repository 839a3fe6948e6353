"""The fluid-method seam: the protocol every particle method implements, and its registry.

``fluid.method`` picks the solver class by name, the way mappings and accelerations are picked
(``coupler/registry.py``): a new method is one package plus one line in :data:`FLUID_METHODS`,
one in :data:`METHOD_TABLES` (and one in :data:`FLUID_PARTICIPANTS` if it couples) (the ``[fluid]`` sub-tables of numerical keys it owns; a table
of another method is refused by the schema). The run loop (``simulation.py``), the results file,
the checkpoints and the probes talk to a solver only through :class:`FluidMethod`.

This module imports no solver: the schema reads the names from it.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any, Protocol, runtime_checkable

import numpy as np

from mpsfem.coupler.registry import Registry

#: method name -> solver class (imported only when asked for)
FLUID_METHODS = Registry(
    "fluid method",
    {
        "mps": "mpsfem.fluid_mps.solver:FluidSolver",
        "delta-sph": "mpsfem.fluid_sph.solver:DeltaSPHSolver",
    },
)

#: method name -> its coupled participant (``coupler.participant`` protocol; imported only when
#: asked for): the fluid side of ``simulation.run_coupled``
FLUID_PARTICIPANTS = Registry(
    "coupled fluid participant",
    {
        "mps": "mpsfem.fluid_mps.participant:FluidParticipant",
        "delta-sph": "mpsfem.fluid_sph.participant:SPHParticipant",
    },
)

#: the [fluid] sub-tables of numerical keys each method owns; the other methods refuse them
METHOD_TABLES: dict[str, tuple[str, ...]] = {
    "mps": ("kernel", "pressure", "surface", "collision"),
    "delta-sph": ("sph",),
}


@runtime_checkable
class FluidMethod(Protocol):
    """What the run loop, the probes, the results file and the checkpoints need of a fluid.

    Arrays are float64 (N, dim) for ``pos``/``vel`` (m, m/s), (N,) for ``p`` (Pa) and int8 for
    ``kind`` (codes of ``fluid_mps.particle_kinds``: 0 fluid, 1 wall, 2 dummy, ...); the
    particle count and order never change during a run.
    """

    spec: Any
    dim: int
    n: int
    n_fluid: int
    pos: np.ndarray
    vel: np.ndarray
    p: np.ndarray
    kind: np.ndarray
    t: float
    step_count: int
    dt_next: float
    #: ``.full`` (bool: rows for /momentum_budget), ``.names``, ``.model``, ``.take(vel, kind)``
    budget: Any
    #: accumulated wall time per stage, ``.as_dict()``
    times: Any

    def step(self, dt: float) -> None:
        """Advance the state by exactly ``dt`` (s); raises on a broken state."""

    def dt_towards(self, t_end: float) -> float:
        """The next step (s) on the way to ``t_end``."""

    def substeps(self, window: float) -> tuple[int, float]:
        """``window`` (s) split into n equal stable steps."""

    def move_walls(self, t: float) -> None:
        """Prescribed wall patches to their position and velocity at ``t`` (s)."""

    def set_patch_state(self, name: str, pos: np.ndarray, vel: np.ndarray) -> None:
        """An external patch's particles (another participant's surface) for the next step."""

    def boundary_force(self, names: Sequence[str]) -> np.ndarray:
        """Force of the fluid on the named patches in the last step, N (N/m in 2D)."""

    def probe_value(self, probe) -> float | np.ndarray:
        """The current value of a fluid probe (``scenario.probes``)."""

    def attach_pressure_ledger(self, ledger) -> None:
        """Book the attached pressure probes' impulses (``fluid_mps.probes``
        ``AttachedPressureLedger``) every step, as part of :meth:`state`."""

    def state(self) -> dict[str, np.ndarray]:
        """Arrays that, with :meth:`meta`, restore the solver bit for bit (views)."""

    def meta(self) -> dict:
        """JSON-able numbers of the state (time, step, next dt, ...)."""

    def restore(self, arrays: dict[str, np.ndarray], meta: dict, preconditioner=None) -> None:
        """Set the state from :meth:`state` / :meth:`meta` (copied in)."""

    def preconditioner_state(self) -> Any:
        """Reused solver data that a bit-identical continuation needs (None if none)."""

    def preconditioner_arrays(self) -> tuple[dict[str, np.ndarray], dict]:
        """That data as arrays and JSON-able numbers, for checkpoint files."""

    def load_preconditioner_arrays(self, arrays: dict[str, np.ndarray], meta: dict | None) -> None:
        """Continue with the data of a checkpoint file."""


def create_fluid_solver(spec, base_dir: Path | None = None, **kwargs: Any) -> FluidMethod:
    """The solver of ``spec.method`` (``fluid.method``) for the ``[fluid]`` section ``spec``."""
    return FLUID_METHODS.create(spec.method, spec, base_dir, **kwargs)


def create_fluid_participant(spec, structure_interface, **kwargs: Any) -> Any:
    """The coupled participant of ``spec.method`` around the structure's interface mesh;
    ``kwargs``: ``base_dir``, ``member_names``, ``free_ends`` (see the participants)."""
    return FLUID_PARTICIPANTS.create(spec.method, spec, structure_interface, **kwargs)
