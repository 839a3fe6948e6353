"""Schema of the ``[structure]`` section of a scenario file.

The structure is a set of independent elastic members: Euler-Bernoulli beams in 2D scenes
(``type = "beam"``, per metre of width like every 2D quantity) and Kirchhoff plates in 3D scenes
(``type = "plate"``). Every physical and numerical parameter is written in the file; geometry is in
scene coordinates (metres), loads in SI units. See docs/structure.md for the model and its conventions.

Sign conventions used throughout:

* A beam runs from ``start`` to ``end``; its tangent is ``t = (end - start) / L`` and its normal
  ``n = (-t_y, t_x)`` (the tangent turned 90 degrees anticlockwise). Transverse deflection, pressure
  and rotation are positive along ``n`` / anticlockwise.
* A plate lies in the plane through ``origin`` spanned by ``axis_u`` and ``axis_v``; its normal is
  ``n = axis_u x axis_v``. Deflection and pressure are positive along ``n``.
"""

from __future__ import annotations

import math
from typing import Annotated, Literal

from pydantic import Field, field_validator, model_validator

from .base import InvalidValue, Section
from .motion import MemberMotion

__all__ = [
    "BoundaryName",
    "Material",
    "StepFunction",
    "RampFunction",
    "HarmonicFunction",
    "TableFunction",
    "TimeFunction",
    "PressureLoad",
    "PointForceLoad",
    "Load",
    "BeamMember",
    "PlateMember",
    "Member",
    "StructureTime",
    "NewtonSettings",
    "StructureSection",
]

BoundaryName = Literal["clamped", "simply_supported", "free"]
"""Support of a beam end or a plate edge."""

NAME_PATTERN = r"^[A-Za-z][A-Za-z0-9_\-]*$"
_NAME_HELP = "letters, digits, '_' and '-', starting with a letter (it names an HDF5 group)"

#: tolerance (m) within which a probe or point force must lie on its member
ON_MEMBER_TOL = 1e-6


# --------------------------------------------------------------------------- materials
class Material(Section):
    """Linear elastic isotropic material of a member."""

    youngs_modulus: float = Field(gt=0, description="Young's modulus E in Pa (> 0).")
    poisson_ratio: float | None = Field(
        None,
        ge=0.0,
        lt=0.5,
        description=(
            "Poisson's ratio nu, 0 <= nu < 0.5. Required for plates (rigidity "
            "D = E h^3 / (12 (1 - nu^2))) and for beams with `plate_strip = true`; unused otherwise."
        ),
    )
    density: float = Field(gt=0, description="Mass density in kg/m^3 (> 0).")


# --------------------------------------------------------------------------- time functions
class StepFunction(Section):
    """f(t) = 0 before `start`, 1 from `start` on (a suddenly applied, then constant load)."""

    kind: Literal["step"] = Field("step", description='"step".')
    start: float = Field(0.0, ge=0, description="Time in s at which the load switches on (>= 0).")


class RampFunction(Section):
    """f(t) rises linearly from 0 at `start` to 1 at `start + duration`, then stays 1."""

    kind: Literal["ramp"] = Field(description='"ramp".')
    start: float = Field(0.0, ge=0, description="Time in s at which the ramp begins (>= 0).")
    duration: float = Field(gt=0, description="Rise time in s (> 0).")


class HarmonicFunction(Section):
    """f(t) = sin(2 pi frequency (t - start) + phase) from `start` on, 0 before."""

    kind: Literal["harmonic"] = Field(description='"harmonic".')
    frequency: float = Field(gt=0, description="Frequency in Hz (> 0).")
    phase: float = Field(0.0, description="Phase in rad at t = start.")
    start: float = Field(0.0, ge=0, description="Time in s at which the excitation begins (>= 0).")


class TableFunction(Section):
    """f(t) interpolated linearly in a table of (t, f) pairs, held at the end values outside it.

    Give the table either inline (`points`) or as a CSV file of two columns t, f (`file`, relative
    to the scenario file's folder; lines starting with '#' and a non-numeric header are skipped).
    """

    kind: Literal["table"] = Field(description='"table".')
    file: str | None = Field(
        None, description="CSV file with columns t [s], f [-]; relative to the scenario's folder."
    )
    points: list[list[float]] | None = Field(
        None, description="Inline table [[t0, f0], [t1, f1], ...], times strictly increasing."
    )

    @model_validator(mode="after")
    def _one_source(self) -> TableFunction:
        if (self.file is None) == (self.points is None):
            raise InvalidValue(
                "points" if self.file is None else "file",
                "give exactly one of `file` (a CSV path) or `points` ([[t, f], ...])",
            )
        if self.points is not None:
            if len(self.points) < 1 or any(len(p) != 2 for p in self.points):
                raise InvalidValue(
                    "points", "`points` must be a non-empty list of [t, f] pairs", self.points
                )
            ts = [p[0] for p in self.points]
            if any(b <= a for a, b in zip(ts, ts[1:], strict=False)):
                raise InvalidValue(
                    "points", "`points` times must be strictly increasing", self.points
                )
        return self


TimeFunction = Annotated[
    StepFunction | RampFunction | HarmonicFunction | TableFunction,
    Field(discriminator="kind"),
]


# --------------------------------------------------------------------------- loads
class PressureLoad(Section):
    """Uniform pressure over a whole member, times a time function (standalone runs only).

    Positive along the member normal (see the module docstring). On a beam the line load is
    `value` N/m per metre of width, whatever the beam's `width`.
    """

    kind: Literal["pressure"] = Field(description='"pressure".')
    member: str = Field(description="Name of the loaded member.")
    value: float = Field(description="Pressure amplitude in Pa, positive along the member normal.")
    time: TimeFunction = Field(
        default_factory=StepFunction,
        description="Time function multiplying `value`; default a step at t = 0.",
    )


class PointForceLoad(Section):
    """A point force at a point of a member, times a time function (standalone runs only).

    In 2D the force is per unit width (N/m) like every 2D force. The component along a beam's axis
    loads its axial degrees of freedom (ignored when `axial = false`); on a plate only the normal
    component acts (plates carry no membrane action).
    """

    kind: Literal["point_force"] = Field(description='"point_force".')
    member: str = Field(description="Name of the loaded member.")
    position: list[float] = Field(
        min_length=2,
        max_length=3,
        description="Point of application in scene coordinates (m); must lie on the member.",
    )
    force: list[float] = Field(
        min_length=2, max_length=3, description="Force vector in scene coordinates (N; N/m in 2D)."
    )
    time: TimeFunction = Field(
        default_factory=StepFunction,
        description="Time function multiplying `force`; default a step at t = 0.",
    )


Load = Annotated[PressureLoad | PointForceLoad, Field(discriminator="kind")]


# --------------------------------------------------------------------------- members
class _MemberCommon(Section):
    name: str = Field(pattern=NAME_PATTERN, description=f"Unique member name: {_NAME_HELP}.")
    material: Material = Field(description="Material of the member.")
    thickness: float = Field(
        gt=0,
        description=(
            "Structural thickness t in m (> 0): sets stiffness and mass (beam: A = width t, "
            "I = width t^3 / 12 unless `area` / `second_moment` are given; plate: h = t)."
        ),
    )
    geometric_thickness: float | None = Field(
        None,
        gt=0,
        description=(
            "Thickness in m the fluid sees (wall particles on both faces at +-1/2 of it); "
            "defaults to `thickness`. The thesis's 3D plate uses 0.015 m here and 0.001 m above."
        ),
    )
    rayleigh_a1: float = Field(
        0.0, ge=0, description="Rayleigh mass coefficient a1 in 1/s of C = a1 M + a2 K (>= 0)."
    )
    rayleigh_a2: float = Field(
        0.0, ge=0, description="Rayleigh stiffness coefficient a2 in s of C = a1 M + a2 K (>= 0)."
    )
    self_weight: bool = Field(
        False, description="Load the member with its own weight (density x volume x gravity)."
    )
    fictitious_mass: float = Field(
        0.0,
        ge=0,
        description=(
            "Fictitious added mass m_f in kg/m^2 (per m^2 of plate; per m of beam and m of "
            "depth in 2D) for implicit coupling at small structure-to-added-mass ratios (>= 0; "
            "0: off). Inside a coupling window's iterations the member solves (M + M_f) a^k + "
            "C v^k + K u^k = F^k + M_f a^{k-1}, M_f lumped on its nodes along its normal; at "
            "convergence the original equation holds. Estimate: the added mass of the member's "
            "first wet mode (docs/coupler.md, 'Fictitious mass'). Needs coupling.scheme = "
            '"implicit" and coupling.transport.kind = "inproc". With fictitious_mass_model = '
            '"potential_flow" a dimensionless factor (>= 0; 1: the operator itself) on the '
            "potential-flow added-mass operator instead of kg/m^2."
        ),
    )
    fictitious_mass_nodes: Literal["wet", "all"] = Field(
        "wet",
        description=(
            'Nodes that carry the fictitious mass: "wet", those with interface load at the '
            "window's start or in its first iterate plus the nodes of every element touching "
            "one, decided once per coupling window (a dry node steps exactly as without it); "
            '"all": every node of the member (the behaviour before this key).'
        ),
    )
    fictitious_wet_pressure: float = Field(
        0.0,
        ge=0,
        description=(
            'With fictitious_mass_nodes = "wet": the interface pressure in Pa (>= 0) a node\'s '
            "load (over its tributary length or area) must exceed for the node to count as wet; "
            "0 (default): any nonzero load (the behaviour before this key). A fluid that puts "
            "noise-level loads on a member just above its surface (MPS: 1e-4 Pa) otherwise "
            "marks the whole member wet."
        ),
    )
    fictitious_wet_margin: int = Field(
        1,
        ge=0,
        description=(
            'With fictitious_mass_nodes = "wet": the elements (>= 0) by which the wet set is '
            "widened around the nodes whose load exceeds fictitious_wet_pressure; 1 (default, the "
            "behaviour before this key): the nodes next to a wet one carry M_f too, ready for a "
            "wetting front that moves in the window; 0: only loaded nodes, so no node carries "
            "M_f that the fluid does not load (docs/coupler.md, 'Which nodes are wet')."
        ),
    )
    fictitious_wet_update: Literal["window", "grow"] = Field(
        "window",
        description=(
            'With fictitious_mass_nodes = "wet": when the wet set is decided. "window" '
            "(default): once per coupling window, from the load at its start and in its first "
            'iterate, kept for its iterations; "grow": also after every later iterate\'s forces '
            "arrive, adding (never removing) the nodes that became wet, so a window whose "
            "first iterate is dry and a later one touches the water carries the fictitious mass "
            "from then on (the set changes at most a finite number of times, the coupler's "
            "acceleration restarts its window each time; docs/coupler.md, 'Fictitious mass')."
        ),
    )
    fictitious_mass_model: Literal["lumped", "potential_flow"] = Field(
        "lumped",
        description=(
            'Shape of the fictitious mass: "lumped", m_f A_i n_i n_i^T on each node (diagonal; '
            'fictitious_mass in kg/m^2); "potential_flow" (beams, 2D only), on each maximal run '
            "of consecutive carrying nodes the impact (high-frequency) potential-flow added-mass "
            "operator of that straight wetted patch, fluid on one face, phi = 0 on the free "
            "surface continuing its line, infinite depth, density fluid.density, times "
            "fictitious_mass (a factor): a full matrix on the normal translations whose modes "
            "carry their own added mass (docs/coupler.md, 'Fictitious mass')."
        ),
    )
    motion: MemberMotion = Field(
        default_factory=MemberMotion,
        description=(
            "Prescribed rigid translation of the whole member, supports included, "
            "[structure.members.motion] (default: at rest). The elastic part is solved in the "
            "moving frame under the inertial load -density x volume x frame acceleration; the "
            "coupler and the records get the absolute displacement and velocity "
            "(docs/structure.md, 'Support motion')."
        ),
    )

    @property
    def fluid_thickness(self) -> float:
        """Geometric thickness seen by the fluid (defaults to the structural one)."""
        return self.thickness if self.geometric_thickness is None else self.geometric_thickness


class BeamMember(_MemberCommon):
    """Euler-Bernoulli beam in a 2D scene (ElementLineHermite), per metre of width."""

    type: Literal["beam"] = Field(description='"beam" (2D scenes).')
    start: list[float] = Field(
        min_length=2, max_length=2, description="First end of the centreline [x, y] in m."
    )
    end: list[float] = Field(
        min_length=2, max_length=2, description="Second end of the centreline [x, y] in m."
    )
    elements: int = Field(ge=1, description="Number of beam elements (>= 1), equal lengths.")
    bc: BoundaryName | list[BoundaryName] = Field(
        description=(
            'Supports: one of "clamped", "simply_supported", "free" for both ends, or a list '
            "[at start, at end]. A simply supported end is pinned (deflection and axial "
            "displacement fixed, rotation free)."
        )
    )
    width: float = Field(
        1.0,
        gt=0,
        description=(
            "Width b in m out of the plane over which `area` and `second_moment` are given "
            "(default 1). The model, its loads and its energies are per metre of width, like "
            "every 2D quantity: it uses A / b and I / b, so b matters only with those overrides."
        ),
    )
    area: float | None = Field(
        None,
        gt=0,
        description="Cross-section area in m^2 of the whole width b (default b x thickness).",
    )
    second_moment: float | None = Field(
        None,
        gt=0,
        description=(
            "Second moment of area in m^4 of the whole width b (default b x thickness^3 / 12)."
        ),
    )
    plate_strip: bool = Field(
        False,
        description=(
            "Use E / (1 - nu^2) instead of E (a plate strip in cylindrical bending, plane "
            "strain); false is the thesis's beam model."
        ),
    )
    axial: bool = Field(
        True,
        description=(
            "Include axial (bar) degrees of freedom, linear elements; false makes the member "
            "inextensible and drops the tangential part of applied forces."
        ),
    )

    kinematics: Literal["linear", "corotational"] = Field(
        "linear",
        description=(
            '"linear": small deflections and rotations (Hermite bending + axial bar, '
            'uncoupled); "corotational": large rotations, small strains (Crisfield\'s 2D '
            "co-rotational beam, dofs ux, uy, theta per node, axial and bending coupled), solved "
            "by Newton iterations in every step. A linear member warns once when a rotation "
            "exceeds 0.1 rad."
        ),
    )

    @field_validator("bc")
    @classmethod
    def _bc_len(cls, v):
        if isinstance(v, list) and len(v) != 2:
            raise ValueError("a list `bc` needs exactly 2 entries: [at start, at end]")
        return v

    @model_validator(mode="after")
    def _distinct_ends(self) -> BeamMember:
        if math.dist(self.start, self.end) <= 0.0:
            raise InvalidValue("end", "`start` and `end` must be distinct points", self.end)
        if self.kinematics == "corotational" and not self.axial:
            raise InvalidValue(
                "axial",
                'kinematics = "corotational" couples axial and bending: it needs `axial = true`',
                self.axial,
            )
        if self.plate_strip and self.material.poisson_ratio is None:
            raise InvalidValue(
                "material.poisson_ratio", "`plate_strip = true` needs `material.poisson_ratio`"
            )
        return self

    @property
    def dim(self) -> int:
        return 2

    @property
    def edge_bcs(self) -> list[str]:
        """Supports [at start, at end]."""
        return list(self.bc) if isinstance(self.bc, list) else [self.bc, self.bc]

    @property
    def length(self) -> float:
        return math.dist(self.start, self.end)

    @property
    def corners(self) -> list[list[float]]:
        """Scene coordinates (m) of the member's ends."""
        return [list(self.start), list(self.end)]

    @property
    def extent(self) -> float:
        """Largest extent of the member, m (its length)."""
        return self.length

    @property
    def area_per_width(self) -> float:
        """Cross-section area per metre of width, A / b (m^2/m): the 2D model's section."""
        return (self.area if self.area is not None else self.width * self.thickness) / self.width

    @property
    def mass_per_area(self) -> float:
        """Mass per area of the mid-line's surface, rho A / b (kg/m^2)."""
        return self.material.density * self.area_per_width


class PlateMember(_MemberCommon):
    """Kirchhoff plate in a 3D scene: ElementQuadBFS (rectangles) or ElementTriMorley (any outline)."""

    type: Literal["plate"] = Field(description='"plate" (3D scenes).')
    element: Literal["bfs", "morley"] = Field(
        description=(
            '"bfs" (Bogner-Fox-Schmit, conforming, rectangles only) or "morley" '
            "(non-conforming triangle, any polygonal outline)."
        )
    )
    origin: list[float] = Field(
        min_length=3,
        max_length=3,
        description=(
            "Scene position (m) of the local origin (u, v) = (0, 0): a rectangle's corner, the "
            "reference point of a polygon's `outline`."
        ),
    )
    axis_u: list[float] = Field(
        [1.0, 0.0, 0.0],
        min_length=3,
        max_length=3,
        description="Direction of the local u axis in scene coordinates (normalised).",
    )
    axis_v: list[float] = Field(
        [0.0, 1.0, 0.0],
        min_length=3,
        max_length=3,
        description="Direction of the local v axis, perpendicular to `axis_u` (normalised).",
    )
    shape: Literal["rectangle", "polygon"] = Field(
        "rectangle", description='"rectangle" (0..a x 0..b) or "polygon" (`outline`, morley only).'
    )
    size: list[float] | None = Field(
        None,
        min_length=2,
        max_length=2,
        description="Rectangle side lengths [a along u, b along v] in m.",
    )
    outline: list[list[float]] | None = Field(
        None,
        description=(
            "Polygon vertices [[u, v], ...] in local coordinates (m), anticlockwise, not closed "
            "(the last vertex connects to the first)."
        ),
    )
    mesh_size: float | None = Field(
        None,
        gt=0,
        description=(
            "Target element edge length in m; a rectangle gets ceil(a / mesh_size) x "
            "ceil(b / mesh_size) cells. Give this or `divisions`."
        ),
    )
    divisions: list[int] | None = Field(
        None,
        min_length=2,
        max_length=2,
        description="Rectangle cells [along u, along v] (each >= 1); give this or `mesh_size`.",
    )
    bc: BoundaryName | list[BoundaryName] = Field(
        description=(
            'Supports: one of "clamped", "simply_supported", "free" for every edge, or a list '
            "with one entry per edge: a rectangle's edges in the order v = 0, u = a, v = b, u = 0 "
            "(anticlockwise from the origin); a polygon's edges from vertex i to i + 1."
        )
    )

    kinematics: Literal["linear", "von_karman"] = Field(
        "linear",
        description=(
            '"linear": small deflections (Kirchhoff bending only); "von_karman": moderately '
            "large deflections, bending coupled to membrane stretching (in-plane dofs u, v on "
            'ElementQuad2; held edges are immovable in-plane), element = "bfs" rectangles only, '
            "solved by Newton iterations in every step."
        ),
    )

    @model_validator(mode="after")
    def _geometry(self) -> PlateMember:
        if self.fictitious_mass_model != "lumped":
            raise InvalidValue(
                "fictitious_mass_model",
                'a plate (3D) takes only the "lumped" fictitious mass; "potential_flow" is the '
                "2D strip operator of a beam's wetted patch",
                self.fictitious_mass_model,
            )
        if self.material.poisson_ratio is None:
            raise InvalidValue("material.poisson_ratio", "a plate needs `material.poisson_ratio`")
        if self.kinematics == "von_karman" and (self.element != "bfs" or self.shape != "rectangle"):
            raise InvalidValue(
                "kinematics",
                'kinematics = "von_karman" needs element = "bfs" and shape = "rectangle"',
                self.kinematics,
            )
        for key in ("axis_u", "axis_v"):
            if not any(getattr(self, key)):
                raise InvalidValue(
                    key, "`axis_u` and `axis_v` must be non-zero vectors", getattr(self, key)
                )
        nu = math.sqrt(sum(c * c for c in self.axis_u))
        nv = math.sqrt(sum(c * c for c in self.axis_v))
        cos = sum(a * b for a, b in zip(self.axis_u, self.axis_v, strict=True)) / (nu * nv)
        if abs(cos) > 1e-9:
            raise InvalidValue(
                "axis_v",
                f"`axis_u` = {self.axis_u} and `axis_v` must be perpendicular",
                self.axis_v,
            )
        if self.shape == "rectangle":
            if self.outline is not None:
                raise InvalidValue(
                    "outline",
                    'shape = "rectangle" needs `size = [a, b]` and no `outline`',
                    self.outline,
                )
            if self.size is None:
                raise InvalidValue("size", 'shape = "rectangle" needs `size = [a, b]`')
            if min(self.size) <= 0:
                raise InvalidValue("size", "`size` entries must be > 0", self.size)
        else:
            if self.size is not None:
                raise InvalidValue(
                    "size",
                    'shape = "polygon" needs `outline = [[u, v], ...]` and no `size`',
                    self.size,
                )
            if self.outline is None:
                raise InvalidValue("outline", 'shape = "polygon" needs `outline = [[u, v], ...]`')
            if len(self.outline) < 3 or any(len(p) != 2 for p in self.outline):
                raise InvalidValue(
                    "outline", "`outline` needs at least 3 vertices [u, v]", self.outline
                )
            if _polygon_area(self.outline) <= 0:
                raise InvalidValue(
                    "outline", "`outline` must be anticlockwise with positive area", self.outline
                )
            if self.element != "morley":
                raise InvalidValue(
                    "element",
                    'a polygonal plate needs element = "morley" (BFS needs rectangles)',
                    self.element,
                )
            if self.divisions is not None:
                raise InvalidValue(
                    "divisions",
                    "a polygonal plate needs `mesh_size` (and no `divisions`)",
                    self.divisions,
                )
        if (self.mesh_size is None) == (self.divisions is None):
            raise InvalidValue(
                "mesh_size" if self.mesh_size is None else "divisions",
                "give exactly one of `mesh_size` or `divisions`",
            )
        if self.divisions is not None and min(self.divisions) < 1:
            raise InvalidValue("divisions", "`divisions` entries must be >= 1", self.divisions)
        if isinstance(self.bc, list) and len(self.bc) != self.n_edges:
            raise InvalidValue(
                "bc",
                f"a list `bc` needs one entry per edge ({self.n_edges} for this {self.shape})",
                self.bc,
            )
        return self

    @property
    def dim(self) -> int:
        return 3

    @property
    def n_edges(self) -> int:
        return 4 if self.shape == "rectangle" else len(self.outline or [])

    @property
    def edge_bcs(self) -> list[str]:
        """Support of every edge, in the order documented for `bc`."""
        return list(self.bc) if isinstance(self.bc, list) else [self.bc] * self.n_edges

    @property
    def local_outline(self) -> list[list[float]]:
        """Polygon of the planform in local (u, v) coordinates, anticlockwise."""
        if self.shape == "rectangle":
            a, b = self.size  # type: ignore[misc]
            return [[0.0, 0.0], [a, 0.0], [a, b], [0.0, b]]
        return [list(p) for p in self.outline]  # type: ignore[union-attr]

    @property
    def corners(self) -> list[list[float]]:
        """Scene coordinates (m) of the planform's vertices."""
        eu, ev = _unit(self.axis_u), _unit(self.axis_v)
        return [
            [o + u * a + v * b for o, a, b in zip(self.origin, eu, ev, strict=True)]
            for u, v in self.local_outline
        ]

    @property
    def extent(self) -> float:
        """Largest extent of the planform, m (its longest vertex-to-vertex distance)."""
        pts = self.local_outline
        return max(math.dist(p, q) for p in pts for q in pts)

    @property
    def mass_per_area(self) -> float:
        """Mass per area of the mid-surface, rho h (kg/m^2)."""
        return self.material.density * self.thickness


Member = Annotated[BeamMember | PlateMember, Field(discriminator="type")]


# --------------------------------------------------------------------------- time
class StructureTime(Section):
    """Time integration of the structure (Newmark-beta, HHT-alpha or generalised-alpha)."""

    dt: float = Field(
        gt=0,
        description=(
            "Structure time step in s (> 0). In coupled runs a coupling window longer than this "
            "is split into equal sub-steps no longer than `dt`."
        ),
    )
    newmark_beta: float = Field(
        0.25,
        gt=0,
        le=0.5,
        description=(
            "Newmark beta, 0 < beta <= 0.5 (0.25 with gamma 0.5: average acceleration, "
            "unconditionally stable, no numerical damping). Not the pressure equation's gamma."
        ),
    )
    newmark_gamma: float = Field(
        0.5,
        ge=0.5,
        le=1.0,
        description=(
            "Newmark gamma, 0.5 <= gamma <= 1 (above 0.5 adds numerical damping). Unconditional "
            "stability needs beta >= (gamma + 1/2)^2 / 4; below that (e.g. linear acceleration, "
            "beta = 1/6) the run checks dt against the stability limit of the highest mode."
        ),
    )
    scheme: Literal["newmark", "hht", "generalized_alpha"] = Field(
        "newmark",
        description=(
            '"newmark" (newmark_beta, newmark_gamma), "hht" (Hilber-Hughes-Taylor alpha '
            "method: beta = (1 - alpha)^2 / 4, gamma = 1/2 - alpha from `hht_alpha`; "
            "unconditionally stable, second order, dissipates high frequencies) or "
            '"generalized_alpha" (Chung & Hulbert 1993, from `rho_inf`: the same, with the '
            "high-frequency dissipation set down to annihilation in one step). Nonlinear "
            '(co-rotational) members, "hht" and "generalized_alpha" are solved with Newton '
            "iterations per step."
        ),
    )
    hht_alpha: float = Field(
        -0.05,
        ge=-1.0 / 3.0,
        le=0.0,
        description=(
            'HHT alpha, -1/3 <= alpha <= 0 (scheme = "hht" only): 0 is average acceleration, '
            "-1/3 the most dissipative (spectral radius at infinity (1 + alpha) / (1 - alpha))."
        ),
    )

    rho_inf: float = Field(
        0.8,
        ge=0.0,
        le=1.0,
        description=(
            "Spectral radius at infinite frequency, 0 <= rho_inf <= 1 (scheme = "
            '"generalized_alpha" only): 1 dissipates nothing (the midpoint rule), 0 removes a '
            "mode far above 1 / dt in one step (for near-massless members whose displacement "
            "follows a noisy load); alpha_m = (2 rho_inf - 1) / (rho_inf + 1), alpha_f = "
            "rho_inf / (rho_inf + 1), gamma = 1/2 - alpha_m + alpha_f, beta = (1 - alpha_m + "
            "alpha_f)^2 / 4."
        ),
    )

    @model_validator(mode="after")
    def _scheme_keys(self) -> StructureTime:
        # a key of another scheme is refused when it differs from its default (a default
        # written out, as model_dump does, is harmless and must validate again)
        defaults = type(self).model_fields
        if self.scheme != "newmark":
            for key in ("newmark_beta", "newmark_gamma"):
                if getattr(self, key) != defaults[key].default:
                    raise InvalidValue(
                        key,
                        f'scheme = "{self.scheme}" sets beta and gamma (from '
                        f"{'hht_alpha' if self.scheme == 'hht' else 'rho_inf'}); leave "
                        "newmark_beta and newmark_gamma out",
                        getattr(self, key),
                    )
        own = {"hht": "hht_alpha", "generalized_alpha": "rho_inf"}
        for scheme, key in own.items():
            if self.scheme != scheme and getattr(self, key) != defaults[key].default:
                raise InvalidValue(
                    key, f'{key} is used only with scheme = "{scheme}"', getattr(self, key)
                )
        return self

    @property
    def alpha_m(self) -> float:
        """Weight of the step-start acceleration in the inertia (generalised-alpha; 0 else)."""
        if self.scheme == "generalized_alpha":
            return (2.0 * self.rho_inf - 1.0) / (self.rho_inf + 1.0)  # Chung & Hulbert eq. 25
        return 0.0

    @property
    def alpha_f(self) -> float:
        """Weight of the step-start state in the forces (-hht_alpha under HHT; 0 Newmark)."""
        if self.scheme == "generalized_alpha":
            return self.rho_inf / (self.rho_inf + 1.0)  # Chung & Hulbert eq. 25
        return -self.hht_alpha if self.scheme == "hht" else 0.0

    @property
    def beta(self) -> float:
        """Newmark beta in effect (from hht_alpha / rho_inf under HHT / generalised-alpha)."""
        if self.scheme == "newmark":
            return self.newmark_beta
        return (1.0 - self.alpha_m + self.alpha_f) ** 2 / 4.0  # Chung & Hulbert eq. 20

    @property
    def gamma(self) -> float:
        """Newmark gamma in effect (from hht_alpha / rho_inf under HHT / generalised-alpha)."""
        if self.scheme == "newmark":
            return self.newmark_gamma
        return 0.5 - self.alpha_m + self.alpha_f  # Chung & Hulbert eq. 17

    @property
    def alpha(self) -> float:
        """HHT's alpha in effect, -alpha_f (0 under the Newmark scheme)."""
        return -self.alpha_f


class NewtonSettings(Section):
    """Newton iterations of nonlinear structure steps (co-rotational members, the HHT scheme)."""

    tolerance: float = Field(
        1e-8,
        gt=0,
        lt=1,
        description=(
            "Converged when the residual norm is at most `tolerance` times the norm of the "
            "forces in balance (inertial + internal + external), 0 < tolerance < 1."
        ),
    )
    max_iterations: int = Field(
        25, ge=1, description="Iterations per step (or load increment) before Newton fails (>= 1)."
    )
    reuse_ratio: float = Field(
        0.01,
        ge=0,
        lt=1,
        description=(
            "Modified Newton: the factorised tangent is kept (across iterations and steps) while "
            "every iteration reduces the residual norm at least by this factor; an iteration that "
            "does not re-forms it at the current iterate. 0 = full Newton (0 <= value < 1)."
        ),
    )
    static_increments: int = Field(
        1,
        ge=1,
        description=(
            'Load increments of the nonlinear static start (initial_state = "static"), >= 1; an '
            "increment whose Newton iterations fail is halved (down to 1/1024 of the load)."
        ),
    )


# --------------------------------------------------------------------------- the section
class StructureSection(Section):
    """The ``[structure]`` section: elastic members, their time integration and prescribed loads.

    Displacement probes of structure points are ``[[probes]]`` of kind "displacement" at the top
    level of the scenario (``target`` = member name); the run's end time is ``run.end_time``.
    """

    members: list[Member] = Field(
        min_length=1,
        description="The elastic members, [[structure.members]] tables; all beams (2D) or plates (3D).",
    )
    time: StructureTime = Field(description="Time integration, [structure.time].")
    gravity: list[float] | None = Field(
        None,
        min_length=2,
        max_length=3,
        description=(
            "Gravity vector in m/s^2 used for self-weight; default [0, -9.81] in 2D and "
            "[0, 0, -9.81] in 3D."
        ),
    )
    initial_state: Literal["rest", "static"] = Field(
        "rest",
        description=(
            '"rest": zero displacement and velocity at t = 0; "static": start from the static '
            "equilibrium under self-weight and the prescribed loads' values at t = 0 (no start-up "
            "transient)."
        ),
    )
    newton: NewtonSettings = Field(
        default_factory=NewtonSettings,
        description=(
            "Newton iterations, [structure.newton]; used by co-rotational members and the "
            '"hht" scheme (linear members under Newmark need none).'
        ),
    )
    loads: list[Load] = Field(
        default_factory=list,
        description=(
            "Prescribed loads, [[structure.loads]]; they act in standalone runs (`mpsfem "
            "structure`) only, in coupled runs the fluid forces take their place."
        ),
    )
    record_interval: float | None = Field(
        None,
        ge=0,
        description=(
            "Interval in s between records of the members' nodal displacements in "
            "/structure/<member> (0: every structure step; default: output.probe_interval)."
        ),
    )

    @property
    def dim(self) -> int:
        """Dimension of the scene: 2 for beams, 3 for plates."""
        return self.members[0].dim

    @property
    def gravity_vector(self) -> list[float]:
        if self.gravity is not None:
            return list(self.gravity)
        return [0.0, -9.81] if self.dim == 2 else [0.0, 0.0, -9.81]

    def member(self, name: str) -> BeamMember | PlateMember:
        for m in self.members:
            if m.name == name:
                return m
        raise KeyError(f"no structure member named {name!r}")

    @model_validator(mode="after")
    def _consistency(self) -> StructureSection:
        names = [m.name for m in self.members]
        for i, m in enumerate(self.members):
            if m.name in names[:i]:
                raise InvalidValue(
                    f"members[{i}].name",
                    f"member names must be unique; members[{names.index(m.name)}] has it too",
                    m.name,
                )
        dim = self.members[0].dim
        for i, m in enumerate(self.members):
            if m.dim != dim:
                raise InvalidValue(
                    f"members[{i}].type",
                    f"members must be all beams (2D scene) or all plates (3D scene); "
                    f"members[0] is a {self.members[0].type!r}",
                    m.type,
                )
        if self.gravity is not None and len(self.gravity) != dim:
            raise InvalidValue(
                "gravity", f"`gravity` needs {dim} components in a {dim}D scene", self.gravity
            )
        for i, m in enumerate(self.members):
            d = m.motion.direction
            if d is not None and len(d) != dim:
                raise InvalidValue(
                    f"members[{i}].motion.direction",
                    f"needs {dim} components in a {dim}D scene",
                    d,
                )
        by_name = {m.name: m for m in self.members}
        for i, load in enumerate(self.loads):
            where = f"loads[{i}]"
            if load.member not in by_name:
                raise InvalidValue(f"{where}.member", f"not one of {names}", load.member)
            if isinstance(load, PointForceLoad):
                for key in ("position", "force"):
                    if len(getattr(load, key)) != dim:
                        raise InvalidValue(
                            f"{where}.{key}",
                            f"`position` and `force` need {dim} components ({dim}D scene)",
                            getattr(load, key),
                        )
                _check_on_member(by_name[load.member], load.position, f"{where}.position")
        return self


# --------------------------------------------------------------------------- geometry helpers
def _polygon_area(poly: list[list[float]]) -> float:
    s = 0.0
    for (x0, y0), (x1, y1) in zip(poly, poly[1:] + poly[:1], strict=True):
        s += x0 * y1 - x1 * y0
    return 0.5 * s


def _point_in_polygon(u: float, v: float, poly: list[list[float]], tol: float) -> bool:
    # on an edge (within tol) counts as inside
    for (x0, y0), (x1, y1) in zip(poly, poly[1:] + poly[:1], strict=True):
        dx, dy = x1 - x0, y1 - y0
        L2 = dx * dx + dy * dy
        s = min(1.0, max(0.0, ((u - x0) * dx + (v - y0) * dy) / L2))
        if math.hypot(u - x0 - s * dx, v - y0 - s * dy) <= tol:
            return True
    inside = False
    for (x0, y0), (x1, y1) in zip(poly, poly[1:] + poly[:1], strict=True):
        if (y0 > v) != (y1 > v):
            xc = x0 + (v - y0) * (x1 - x0) / (y1 - y0)
            if u < xc:
                inside = not inside
    return inside


def local_coordinates(
    member: BeamMember | PlateMember, point: list[float]
) -> tuple[list[float], float]:
    """Local coordinates of a scene point and its distance from the member's line / plane.

    Beam: ([s], distance) with s the arc length from `start`. Plate: ([u, v], distance).
    """
    if isinstance(member, BeamMember):
        L = member.length
        tx = (member.end[0] - member.start[0]) / L
        ty = (member.end[1] - member.start[1]) / L
        dx, dy = point[0] - member.start[0], point[1] - member.start[1]
        return [dx * tx + dy * ty], abs(-dx * ty + dy * tx)
    eu = _unit(member.axis_u)
    ev = _unit(member.axis_v)
    n = _unit(_cross(eu, ev))
    d = [p - o for p, o in zip(point, member.origin, strict=True)]
    return [_dot(d, eu), _dot(d, ev)], abs(_dot(d, n))


def distance_to_member(member: BeamMember | PlateMember, point: list[float]) -> float:
    """Distance (m) from a scene point to the member's mid-line segment / mid-surface planform."""
    loc, off = local_coordinates(member, point)
    if isinstance(member, BeamMember):
        s = loc[0]
        along = max(0.0, -s, s - member.length)
        return math.hypot(along, off)
    u, v = loc
    if _point_in_polygon(u, v, member.local_outline, 0.0):
        return off
    poly = member.local_outline
    edge = min(
        _segment_distance(u, v, p0, p1) for p0, p1 in zip(poly, poly[1:] + poly[:1], strict=True)
    )
    return math.hypot(edge, off)


def _segment_distance(u: float, v: float, p0: list[float], p1: list[float]) -> float:
    dx, dy = p1[0] - p0[0], p1[1] - p0[1]
    t = min(1.0, max(0.0, ((u - p0[0]) * dx + (v - p0[1]) * dy) / (dx * dx + dy * dy)))
    return math.hypot(u - p0[0] - t * dx, v - p0[1] - t * dy)


def _check_on_member(member: BeamMember | PlateMember, point: list[float], where: str) -> None:
    loc, dist = local_coordinates(member, point)
    if dist > ON_MEMBER_TOL:
        raise InvalidValue(
            where, f"{dist:.3g} m off member {member.name!r} (allowed {ON_MEMBER_TOL} m)", point
        )
    if isinstance(member, BeamMember):
        s = loc[0]
        if s < -ON_MEMBER_TOL or s > member.length + ON_MEMBER_TOL:
            raise InvalidValue(where, f"beyond the ends of member {member.name!r}", point)
    elif not _point_in_polygon(loc[0], loc[1], member.local_outline, ON_MEMBER_TOL):
        raise InvalidValue(where, f"outside the planform of member {member.name!r}", point)


def _unit(a: list[float]) -> list[float]:
    n = math.sqrt(sum(c * c for c in a))
    return [c / n for c in a]


def _cross(a: list[float], b: list[float]) -> list[float]:
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def _dot(a: list[float], b: list[float]) -> float:
    return sum(x * y for x, y in zip(a, b, strict=True))
