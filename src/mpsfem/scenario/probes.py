"""Schema of ``[[probes]]``: what a run measures and records in ``/probes/<name>``.

The exact definition of each kind (radius, connectivity, offsets) is in docs/results.md ("Probe
definitions") and in the docstrings of ``mpsfem.fluid_mps.probes``.
"""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import Field, field_validator, model_validator

from mpsfem.scenario.base import InvalidValue, Section

Vector = list[float]


class _Probe(Section):
    name: str = Field(
        min_length=1,
        max_length=64,
        pattern=r"^[A-Za-z0-9_.-]+$",
        description="probe name (HDF5 group): letters, digits, '_', '.', '-'; not '.' or '..'",
    )
    interval: float | None = Field(
        None, ge=0.0, description="sampling interval, s (default: output.probe_interval)"
    )

    @field_validator("name")
    @classmethod
    def _hdf5_name(cls, v: str) -> str:
        """'.' and '..' are no HDF5 group names (they name the group itself and its parent)."""
        if v.strip(".") == "":
            raise ValueError("must not be only dots ('.' and '..' are no HDF5 group names)")
        return v


class PressureProbe(_Probe):
    """Pressure at a point: mean over fluid and pressure-wall particles within a radius; with
    ``attach``, over the attached wall's or member's pressure-layer particles, riding with it."""

    kind: Literal["pressure"]
    position: Vector = Field(description="gauge point, m; inside the fluid domain")
    radius: float | None = Field(None, gt=0.0, description="averaging radius, m (default 1.0 l0)")
    attach: str | None = Field(
        None,
        min_length=1,
        description="wall (fluid.walls[].name) or structure member the probe rides with: a "
        "member 'm' takes both faces, 'm+' / 'm-' one face. Then ``position`` is in the "
        "reference configuration (t = 0) and the value is the mean pressure of that patch's "
        "pressure-layer particles within ``radius`` of it there, followed as they move (rigid "
        "motion and elastic deflection); unset: a fixed point (fluid and wall particles)",
    )
    average: bool = Field(
        True,
        description="with attach only: true: the mean pressure since the probe's previous "
        "sample (its pressure impulse over the interval, accumulated every step, divided by "
        "the interval), so that samples integrate to the impulse however coarse the "
        "sampling; false: the pressure of the last step (the earlier behaviour; it aliases "
        "the step-to-step pressure noise)",
    )

    @model_validator(mode="after")
    def _average_needs_attach(self) -> PressureProbe:
        if not self.average and self.attach is None:
            raise InvalidValue(
                "average",
                "applies to attached pressure probes only (set attach); a fixed pressure "
                "probe always reports the pressure of the last step",
                self.average,
            )
        return self


class WaveGaugeProbe(_Probe):
    """Free-surface elevation above ``reference_level`` at horizontal position ``position``."""

    kind: Literal["wave_gauge"]
    position: Vector = Field(
        description="x (2D) or (x, y) (3D) of the gauge, m; inside the fluid domain"
    )
    reference_level: float = Field(0.0, description="elevation is measured from this height, m")
    method: Literal["kernel", "top_particle"] = Field(
        "kernel",
        description=(
            "'kernel': height where the kernel-summed fluid fraction along the vertical line "
            "falls to 1/2 (Wendland C2, h = 1.5 l0; continuous in time; keep 3 l0 from walls); "
            "'top_particle': highest fluid particle centre within half_width of the line plus "
            "l0/2 (jumps by up to l0 when the top particle leaves the column)"
        ),
    )
    half_width: float | None = Field(
        None,
        gt=0.0,
        description="horizontal search half-width, m (default 0.5 l0); 'top_particle' only",
    )

    @model_validator(mode="after")
    def _half_width_needs_top_particle(self) -> WaveGaugeProbe:
        if self.half_width is not None and self.method != "top_particle":
            raise InvalidValue(
                "half_width",
                f"used by method = 'top_particle' only; method = {self.method!r} takes no "
                "half_width",
                self.half_width,
            )
        return self


class FrontProbe(_Probe):
    """Largest coordinate along ``axis`` of fluid connected to the bulk (surge front)."""

    kind: Literal["front"]
    axis: int = Field(0, ge=0, le=2, description="coordinate axis of the front")
    link_distance: float = Field(
        1.5, gt=1.0, le=4.0, description="particles closer than this x l0 are connected"
    )
    min_cluster_fraction: float = Field(
        0.5,
        gt=0.0,
        le=1.0,
        description="only clusters holding at least this fraction of the largest one count",
    )


class ForceProbe(_Probe):
    """Force of the fluid on a named wall patch or structure member (``fluid.boundary_force``
    says which contributions), N (N/m in 2D)."""

    kind: Literal["force"]
    target: str = Field(description="name of a wall (fluid.walls[].name) or structure member")
    average: bool = Field(
        True,
        description="true: the mean force since the probe's previous sample (its impulse over "
        "the interval divided by the interval), so that samples integrate to the impulse the "
        "boundary received however coarse the sampling; false: the force of the last step "
        "(the earlier behaviour; it aliases the step-to-step pressure noise)",
    )


class DisplacementProbe(_Probe):
    """Displacement of member ``target`` at ``position``, m, taken at the projection of
    ``position`` on the member's reference mid-line / mid-surface: in coupled runs the linear
    interpolation of the nodal displacements there, in standalone structure runs the member's
    finite-element interpolation."""

    kind: Literal["displacement"]
    target: str = Field(description="structure member name")
    position: Vector = Field(
        description="reference position on the member, m; at most 10 % of the member's extent "
        "(a beam's length, a plate's longest vertex-to-vertex distance) from its mid-line / "
        "mid-surface"
    )


class EnergyProbe(_Probe):
    """Energies of a participant, J (J/m in 2D): fluid kinetic and potential, or structure."""

    kind: Literal["energy"]
    target: str = Field("fluid", description="'fluid' or a structure member name")


Probe = Annotated[
    PressureProbe | WaveGaugeProbe | FrontProbe | ForceProbe | DisplacementProbe | EnergyProbe,
    Field(discriminator="kind"),
]
