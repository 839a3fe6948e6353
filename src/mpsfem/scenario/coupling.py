"""The ``[coupling]`` section: scheme, window, mapping, acceleration, convergence, transport.

Mapping, acceleration and transport are tables chosen by ``kind``; the allowed kinds and their
keys come from the coupler's registries (:mod:`mpsfem.coupler.mapping`,
:mod:`mpsfem.coupler.acceleration`, :mod:`mpsfem.coupler.transport`), so a new component is
usable in scenarios as soon as it is registered. Example::

    [coupling]
    scheme = "implicit"          # or "explicit" (the thesis's weak coupling)
    # window = 1e-4              # default: the structure's time step

    [coupling.mapping]
    kind = "shape-function"      # "kfbi" | "conservative-kernel" | "shape-function"

    [coupling.acceleration]
    kind = "iqn-ils"             # "constant" | "aitken" | "iqn-ils" | "iqn-imvj"
    reuse_windows = 8
    # kind = "iqn-imvj"          # Jacobian carried across windows (extreme added mass)
    # restart = "no-restart"     # "RS-SVD" | "RS-LS" | "RS-0" (chunk_size windows)
    # data = ["displacement", "velocity"]
    # preconditioner = "value"   # "none" | "value" | "residual_sum"
    # complement_relaxation = "auto"

    [coupling.convergence]
    relative_tolerance = 1e-4
    absolute_tolerance = 1e-9
    max_iterations = 50
    on_divergence = "stop"       # or "continue" (accept, record a warning)

    [coupling.transport]
    kind = "inproc"              # "inproc" | "mpi" | "zenoh" (or --transport)
    timeout_s = 10.0
"""

from __future__ import annotations

from typing import Annotated, Any, Literal, Union

from pydantic import Field, field_validator, model_validator

from mpsfem.coupler import SCHEMES
from mpsfem.coupler.acceleration import ACCELERATIONS
from mpsfem.coupler.mapping import MAPPINGS
from mpsfem.coupler.transport import TRANSPORTS
from mpsfem.scenario.base import Section

__all__ = ["CouplingSection", "ConvergenceSection"]


def _by_kind(registry) -> Any:
    """Discriminated union (on ``kind``) of the ``Params`` sections of a registry's entries."""
    models = tuple(registry.get(name).Params for name in registry)
    if len(models) == 1:
        return models[0]
    return Annotated[Union[models], Field(discriminator="kind")]  # noqa: UP007


MappingConfig = _by_kind(MAPPINGS)
AccelerationConfig = _by_kind(ACCELERATIONS)
TransportConfig = _by_kind(TRANSPORTS)


def _default(registry, kind: str):
    return lambda: registry.get(kind).Params(kind=kind)


class ConvergenceSection(Section):
    """When an implicit window has converged, and what to do when it does not."""

    relative_tolerance: float = Field(
        1e-4,
        gt=0,
        lt=1,
        description=(
            "Converged when rms(x_tilde - x) <= max(relative_tolerance * rms(x_tilde), "
            "absolute_tolerance): x the interface displacement the fluid used, x_tilde the "
            "structure's answer, on the structure nodes. In (0, 1)."
        ),
    )
    absolute_tolerance: float = Field(
        1e-9,
        gt=0,
        description=(
            "Absolute floor of the residual in m (> 0), for displacements near zero (a "
            "structure at rest)."
        ),
    )
    relative_to: Literal["displacement", "window_motion"] = Field(
        "displacement",
        description=(
            "Scale of the relative tolerance: 'displacement', rms(x_tilde), the whole interface "
            "displacement (preCICE's relative measure); 'window_motion', rms(x_tilde - d_n), the "
            "interface's motion within the window, about 100 times stricter where a window "
            "moves the interface by a percent of its displacement and the choice that bounds the "
            "interface work error (docs/coupler.md)."
        ),
    )
    fictitious_force_tolerance: float | Literal["off"] = Field(
        1e-2,
        description=(
            "With a member's fictitious_mass > 0: a window is converged only when, in every "
            "structure sub-step, the force the fictitious mass leaves in the member's equation, "
            "rms(M_f (a^k - a^{k-1})) over the nodes it acts on, is at most this times the "
            "larger of the largest rms interface load on those nodes in the window and in any "
            "earlier window (or within fictitious_force_floor); a number in (0, 1), "
            'docs/coupler.md, "Fictitious mass". "off": the displacement residual alone '
            "decides (the behaviour before this key). Ignored without a fictitious mass."
        ),
    )
    fictitious_force_floor: float = Field(
        0.01,
        ge=0,
        description=(
            "Absolute floor in Pa (>= 0) of fictitious_force_tolerance's test: a fictitious "
            "force error whose rms per unit of interface (N/m^2; in 2D N/m per m) is at most "
            "this passes, whatever the load (a member touched only by near-surface noise, "
            "about 1e-4 Pa in MPS, cannot converge a fraction of it). 0.01 Pa is 1 micron of "
            "water head."
        ),
    )
    min_iterations: int = Field(1, ge=1, description="Fewest iterations per window (>= 1).")
    max_iterations: int = Field(
        50, ge=1, description="Most iterations per window (>= min_iterations)."
    )
    on_divergence: Literal["stop", "continue"] = Field(
        "stop",
        description=(
            'A window not converged after max_iterations: "stop" ends the run with '
            'CouplingNotConvergedError; "continue" accepts the last iterate and records a '
            "warning. Non-finite values and detected blow-up always stop."
        ),
    )
    accept_unconverged: Literal["last", "best"] = Field(
        "last",
        description=(
            'With on_divergence = "continue", which iterate of a window not converged after '
            'max_iterations is accepted: "last" (the behaviour before this key) or "best", the '
            "one nearest the criteria (smallest max(residual / relative_tolerance, fictitious "
            "force error / fictitious_force_tolerance)), re-run by both participants (one more "
            "iteration) so that the accepted pair is its own. An accelerator cycling across a "
            "discontinuity of the fluid's map (a wall dry at one iterate, wet at the next) can "
            'end on its worst iterate; docs/coupler.md, "Unconverged windows".'
        ),
    )
    retreat_predictor: bool = Field(
        False,
        description=(
            "A first iterate of an implicit window (the predictor d_n + T v_n) that a "
            "participant rejects (a structure's Newton failing, a fluid particle thrown out) is "
            "retried at 1/4 of its step from the window's start (d_n, v_n), at most 4 times, "
            "as later rejected iterates are from the last completed one; false (the behaviour "
            'before this key): the error ends the run. docs/coupler.md, "Rejected iterates".'
        ),
    )
    max_displacement: float | None = Field(
        None,
        gt=0,
        description=(
            "Optional bound in m (> 0): an interface displacement beyond it stops the run as "
            "diverged."
        ),
    )

    @field_validator("fictitious_force_tolerance")
    @classmethod
    def _force_tolerance(cls, v: float | str) -> float | str:
        if v != "off" and not 0.0 < v < 1.0:
            raise ValueError('must be a number in (0, 1) or "off"')
        return v

    @model_validator(mode="after")
    def _iterations(self) -> ConvergenceSection:
        if self.min_iterations > self.max_iterations:
            raise ValueError(
                f"min_iterations = {self.min_iterations} must be <= max_iterations = "
                f"{self.max_iterations}"
            )
        return self


class CouplingSection(Section):
    """Partitioned fluid-structure coupling (thesis ch. 2.3; preCICE-style components)."""

    scheme: str = Field(
        "implicit",
        description=(
            '"explicit": serial-staggered, one exchange per window (the thesis\'s weak '
            'coupling); "implicit": serial, iterated to convergence in every window with '
            "checkpoint/restore of both participants and acceleration."
        ),
    )
    window: float | None = Field(
        None,
        gt=0,
        description=(
            "Coupling window in s (> 0): the time between two data exchanges. Default: the "
            "structure's time step. The fluid sub-cycles in equal steps landing on window ends; "
            "a window longer than the structure's dt sub-cycles the structure too."
        ),
    )
    force_sampling: Literal["mean", "end"] = Field(
        "mean",
        description=(
            'Fluid force handed to the structure for a window: "mean", the time average over '
            "the fluid's sub-steps (independent of the sub-step count, smooths MPS pressure "
            'noise); "end", the force of the last sub-step.'
        ),
    )
    predictor: Literal["velocity", "constant", "linear"] = Field(
        "velocity",
        description=(
            'First iterate of a window\'s interface displacement: "velocity", d_n + T v_n (the '
            "structure's velocity; consistent for Newmark's average acceleration); "
            '"constant", d_n; "linear", d_n + T (d_n - d_n-1) / T_n-1 (preCICE\'s extrapolation '
            "orders 0 and 1). For members so light that their velocity jumps from window to "
            "window (docs/coupler.md, 'Predictor and interface velocity')."
        ),
    )
    interface_velocity: Literal["structure", "displacement_rate"] = Field(
        "structure",
        description=(
            'Velocity of the fluid\'s interface points inside a window: "structure", the '
            "structure's velocity at the window's ends (v_n, and the iterate's at t_n + T), "
            'linearly interpolated; "displacement_rate", the rate of the motion the fluid is '
            "given, (H x - H d_n) / T, constant in the window (the points move linearly "
            "between H d_n and H x, so it is their own velocity). For members so light that "
            "their Newmark velocity alternates from window to window while they move a "
            "fraction of a millimetre (docs/coupler.md, 'Predictor and interface velocity')."
        ),
    )
    mapping: MappingConfig = Field(
        default_factory=_default(MAPPINGS, "shape-function"),
        description=(
            f"Interface mapping, by kind: {', '.join(repr(k) for k in MAPPINGS)}. Default: "
            '"shape-function".'
        ),
    )
    acceleration: AccelerationConfig = Field(
        default_factory=_default(ACCELERATIONS, "iqn-ils"),
        description=(
            "Acceleration of implicit coupling, by kind: "
            f'{", ".join(repr(k) for k in ACCELERATIONS)}. Default: "iqn-ils".'
        ),
    )
    convergence: ConvergenceSection = Field(
        default_factory=ConvergenceSection,
        description="Convergence criterion and failure handling.",
    )
    transport: TransportConfig = Field(
        default_factory=_default(TRANSPORTS, "inproc"),
        description=(
            f"How the participants talk, by kind: {', '.join(repr(k) for k in TRANSPORTS)} "
            '(--transport overrides the kind). Default: "inproc".'
        ),
    )

    @field_validator("scheme")
    @classmethod
    def _scheme(cls, v: str) -> str:
        if v not in SCHEMES:
            raise ValueError(f"allowed: {', '.join(repr(s) for s in SCHEMES)}")
        return v
