"""The root scenario model: one schema shared by every participant."""

from __future__ import annotations

import warnings

from pydantic import Field, model_validator

from mpsfem.scenario.base import InvalidValue, Section
from mpsfem.scenario.coupling import CouplingSection
from mpsfem.scenario.fluid import FluidSection
from mpsfem.scenario.limits import check_limits
from mpsfem.scenario.output import OutputSection, RunSection
from mpsfem.scenario.probes import Probe
from mpsfem.scenario.structure import StructureSection, distance_to_member


class LinkWarning(UserWarning):
    """A co-rotational member coupled through the linear rigid link
    (``coupling.mapping.large_rotation = false`` set by the scenario)."""


class AddedMassWarning(UserWarning):
    """A member far lighter than the water it meets, under coupling settings that the stress
    sweeps did not see converge at its mass ratio (docs/coupler.md, "Light members")."""


#: mass ratios (rho_s h) / (rho_w H) below which the stress sweeps saw a fluid method's defaults
#: fail (docs/coupler.md, "Light members: what to set, by mass ratio"): under MPS the plate
#: converged down to 1e-2 (the obstacle at 1e-2 needed the shaped fictitious mass already) and
#: below it only with a fictitious mass (the obstacle to 1e-3 with the collision ramp as well);
#: under δ-SPH both converged down to 1e-3, and at 1e-4 the obstacle needed the safeguards
LIGHT_MEMBER_RATIO = {"mps": 1e-2, "delta-sph": 1e-3}
#: under δ-SPH, the coupling window times c0 / l0 above which a member lighter than
#: LIGHT_MEMBER_RATIO is advised: the light bottom-slamming plate (mass ratio 2e-4) carries a
#: load oscillation at 0.81 c0 / l0 that a window of 3.7 l0 / c0 put at its Nyquist frequency
#: (the runs stopped at A/H = 0.4 and 0.5), while 1.9 and 2.8 l0 / c0 reached their ends
#: (docs/validation_bottom_slamming_light.md, "The window against the fluid's sound speed")
SPH_WINDOW_SOUND_LIMIT = 3.0

#: a displacement probe may lie at most this fraction of its member's extent (a beam's length, a
#: plate's longest vertex-to-vertex distance) from the member's mid-line / mid-surface
DISPLACEMENT_PROBE_TOLERANCE = 0.1
DOMAIN_DEFAULT = "default: the blocks', walls' and members' box grown by 10 l0, 1 m upwards"


class Scenario(Section):
    """A scenario file: ``[run]``, ``[output]``, ``[fluid]``, ``[[probes]]`` (and, for coupled
    runs, ``[structure]`` and ``[coupling]``)."""

    title: str = Field("", description="free text describing the case")
    run: RunSection = Field(description="run control")
    output: OutputSection = Field(default_factory=OutputSection, description="results output")
    fluid: FluidSection | None = Field(None, description="MPS fluid participant")
    structure: StructureSection | None = Field(None, description="FEM structure participant")
    coupling: CouplingSection | None = Field(
        None, description="fluid-structure coupling (needs [fluid] and [structure])"
    )
    probes: list[Probe] = Field(default_factory=list, description="measurements")

    def _large_rotation_link(self) -> None:
        """Co-rotational members turn the shape-function mapping's rigid link exactly
        (``coupling.mapping.large_rotation``) unless the scenario sets it: the linear link of
        a member turned 0.65 rad moves its faces' particles by millimetres off the member."""
        mapping = getattr(self.coupling, "mapping", None) if self.coupling is not None else None
        if mapping is None or "large_rotation" not in type(mapping).model_fields:
            return
        corot = [
            m.name
            for m in self.structure.members
            if getattr(m, "kinematics", "linear") == "corotational"
        ]
        if "large_rotation" in mapping.model_fields_set:
            if corot and not mapping.large_rotation:
                warnings.warn(
                    "coupling.mapping.large_rotation = false with co-rotational member(s) "
                    f"{', '.join(map(repr, corot))}: the linear rigid link moves the faces' "
                    "particles off a member that turns far (millimetres at 0.65 rad); leave the "
                    "key out (or set it true) unless reproducing a linear-link run",
                    LinkWarning,
                    stacklevel=2,
                )
            return
        if corot:
            mapping.large_rotation = True

    def mass_ratios(self) -> dict[str, float]:
        """Each member's mass ratio (rho_s h) / (rho_w H): its mass per area
        (``mass_per_area``) over that of the water, H = ``fluid.water_height`` (the initial
        depth or column height). {} without fluid or structure."""
        if self.fluid is None or self.structure is None:
            return {}
        water = self.fluid.density * self.fluid.water_height
        return {m.name: m.mass_per_area / water for m in self.structure.members}

    def _light_member_advice(self) -> None:
        """Warn (:class:`AddedMassWarning`) where a member's mass ratio lies below what the
        fluid method's defaults converged at in the stress sweeps and the scenario sets none
        of the remedies measured there: a fictitious mass under MPS, the safeguards
        (``coupling.convergence.accept_unconverged = "best"``) under δ-SPH."""
        if self.coupling is None:
            return
        method = self.fluid.method
        limit = LIGHT_MEMBER_RATIO.get(method)
        if limit is None:
            return
        ratios = self.mass_ratios()
        safeguards = self.coupling.convergence.accept_unconverged == "best"
        H = self.fluid.water_height
        for m in self.structure.members:
            ratio = ratios[m.name]
            if ratio >= limit * (1.0 - 1e-9):
                continue
            if method == "mps" and m.fictitious_mass > 0.0:
                continue
            if method == "delta-sph" and safeguards:
                continue
            remedy = (
                'a static start under water at rest (structure.initial_state = "static": the '
                "hydrostatic plate then converged down to 1e-4 with the defaults) and, under an "
                "impact, a fictitious mass (structure.members.N.fictitious_mass; on the dam-break "
                "obstacle under MPS the shaped one with fluid.collision.ramp = 0.1 converged "
                "down to 1e-3, and at 1e-4 only with the water weakly compressible "
                "(fluid.pressure.compressibility at a sound speed of 10 u_max, shifting 0.1) "
                "and coupling.acceleration.relaxation_bounds = [0.05, 20]; δ-SPH converged to "
                "1e-3 with its defaults and at 1e-4 with its safeguards)"
                if method == "mps"
                else 'the safeguards (coupling.convergence.accept_unconverged = "best", '
                "retreat_predictor, the HHT scheme) and a member several spacings thick (3.3 "
                "converged, 1.6 did not)"
            )
            warnings.warn(
                f"structure member {m.name!r}: mass ratio (rho_s h) / (rho_w H) = {ratio:.2g} "
                f"(H = {H:.3g} m, the fluid blocks' depth), below {limit:g}, where the "
                f"coupling stress sweeps saw the {method} fluid's defaults fail to converge; "
                f"they needed {remedy}. See docs/coupler.md, 'Light members: what to set, by "
                "mass ratio'",
                AddedMassWarning,
                stacklevel=2,
            )

    def _delta_sph_window_advice(self) -> None:
        """Warn (:class:`AddedMassWarning`) where a δ-SPH scenario couples a member lighter than
        LIGHT_MEMBER_RATIO implicitly in windows longer than SPH_WINDOW_SOUND_LIMIT l0 / c0."""
        if self.coupling is None or self.coupling.scheme != "implicit":
            return
        fluid = self.fluid
        if fluid.method != "delta-sph":
            return
        limit = LIGHT_MEMBER_RATIO["delta-sph"]
        light = [name for name, r in self.mass_ratios().items() if r < limit * (1.0 - 1e-9)]
        c0 = fluid.sph_sound_speed()
        if not light or not c0 > 0.0:
            return
        window = self.coupling.window or self.structure.time.dt
        number = window * c0 / fluid.spacing
        if number <= SPH_WINDOW_SOUND_LIMIT:
            return
        names = ", ".join(repr(n) for n in light)
        bound = SPH_WINDOW_SOUND_LIMIT * fluid.spacing / c0
        warnings.warn(
            f"structure member(s) {names}: mass ratio below {limit:g} under δ-SPH with "
            f"coupling.window = {window:g} s = {number:.2g} l0 / c0 (c0 = {c0:.3g} m/s, l0 = "
            f"{fluid.spacing:g} m): such a member's load oscillates at about 0.81 c0 / l0, "
            "which a window of 3.7 l0 / c0 put at its Nyquist frequency on the light "
            "bottom-slamming plate (the runs stopped); windows of 1.9-2.8 l0 / c0 reached their "
            f"ends. Consider coupling.window <= {bound:.3g} s ({SPH_WINDOW_SOUND_LIMIT:g} l0 / "
            "c0). See docs/fluid_sph.md, 'The coupling window against c0 / l0'",
            AddedMassWarning,
            stacklevel=2,
        )

    @model_validator(mode="after")
    def _check(self) -> Scenario:
        check_limits(self)  # first: coordinates and sizes the other checks compute with
        seen: dict[str, int] = {}
        for i, p in enumerate(self.probes):
            if p.name in seen:
                raise InvalidValue(
                    f"probes[{i}].name",
                    f"probe names must be unique; probes[{seen[p.name]}] has it too",
                    p.name,
                )
            seen[p.name] = i
        if self.fluid is not None and self.structure is not None:
            if self.structure.dim != self.fluid.dim:
                raise InvalidValue(
                    "structure.members[0].type",
                    f"a {self.structure.dim}D member in a scene of fluid.dim = {self.fluid.dim} "
                    "(beams in 2D, plates in 3D)",
                    self.structure.members[0].type,
                )
        scene = self.fluid if self.fluid is not None else self.structure
        if scene is not None:
            d = scene.dim
            for i, p in enumerate(self.probes):
                pos = getattr(p, "position", None)
                want = d - 1 if p.kind == "wave_gauge" else d
                if pos is not None and len(pos) != want:
                    raise InvalidValue(
                        f"probes[{i}].position", f"must have {want} components (dim = {d})", pos
                    )
                if p.kind == "front" and p.axis >= d:
                    raise InvalidValue(f"probes[{i}].axis", f"must be < dim = {d}", p.axis)
        if self.fluid is not None:
            self._check_inside_domain()
        if self.structure is not None:
            self._check_displacement_probes_on_members()
            self._large_rotation_link()
            if self.fluid is not None:
                self._light_member_advice()
                self._delta_sph_window_advice()
        if self.fluid is not None:
            walls = {w.name for w in self.fluid.walls if w.name}
            if self.structure is not None:
                walls |= {m.name for m in self.structure.members}
            for i, p in enumerate(self.probes):
                if p.kind == "force" and p.target not in walls:
                    raise InvalidValue(
                        f"probes[{i}].target",
                        f"names no wall patch or structure member; have {sorted(walls)}",
                        p.target,
                    )
                attach = getattr(p, "attach", None)
                member_names = {m.name for m in self.structure.members} if self.structure else set()
                face = attach is not None and attach[-1:] in ("+", "-")
                if (
                    attach is not None
                    and attach not in walls
                    and not (face and attach[:-1] in member_names)
                ):
                    raise InvalidValue(
                        f"probes[{i}].attach",
                        f"names no wall or structure member (a member's face: its name + '+' "
                        f"or '-'); have {sorted(walls)}",
                        attach,
                    )
        members = {m.name for m in self.structure.members} if self.structure else set()
        for i, p in enumerate(self.probes):
            if p.kind == "displacement" and p.target not in members:
                raise InvalidValue(
                    f"probes[{i}].target",
                    f"names no structure member; have {sorted(members)}",
                    p.target,
                )
            if p.kind == "energy" and p.target != "fluid" and p.target not in members:
                raise InvalidValue(
                    f"probes[{i}].target",
                    f"must be 'fluid' or a structure member {sorted(members)}",
                    p.target,
                )
        if self.coupling is not None and (self.fluid is None or self.structure is None):
            raise InvalidValue(
                "coupling", "[coupling] needs both a [fluid] and a [structure] section"
            )
        if self.structure is not None and self.coupling is not None:
            for i, m in enumerate(self.structure.members):
                if m.fictitious_mass > 0 and self.coupling.scheme != "implicit":
                    raise InvalidValue(
                        f"structure.members[{i}].fictitious_mass",
                        "acts inside the iterations of implicit coupling windows only; "
                        f'coupling.scheme is {self.coupling.scheme!r}: set it to "implicit" or '
                        "the fictitious mass to 0",
                        m.fictitious_mass,
                    )
                if m.fictitious_mass > 0 and self.coupling.transport.kind != "inproc":
                    raise InvalidValue(
                        f"structure.members[{i}].fictitious_mass",
                        "needs the structure in the fluid's process (coupling.transport.kind = "
                        f'"inproc"; it is {self.coupling.transport.kind!r}): a remote structure '
                        "is not handed the interface iterate its fictitious mass must answer to",
                        m.fictitious_mass,
                    )
        if self.fluid is None and self.structure is None:
            raise ValueError("a scenario needs a [fluid] or a [structure] section (or both)")
        return self

    def _check_inside_domain(self) -> None:
        """Fluid probes with a position and (coupled) structure members lie in the fluid domain."""
        fluid = self.fluid
        members = self.structure.members if self.structure is not None else []
        lo, hi = fluid.domain_box([c for m in members for c in m.corners])
        box = f"the fluid domain {lo} .. {hi} (fluid.domain_lower/upper, {DOMAIN_DEFAULT})"
        up = fluid.vertical_axis
        for i, p in enumerate(self.probes):
            if p.kind not in ("pressure", "wave_gauge"):
                continue
            axes = [a for a in range(fluid.dim) if p.kind == "pressure" or a != up]
            if any(not lo[a] <= x <= hi[a] for a, x in zip(axes, p.position, strict=True)):
                raise InvalidValue(f"probes[{i}].position", f"lies outside {box}", p.position)
        for i, m in enumerate(members):
            for c in m.corners:
                if any(not lo[a] <= x <= hi[a] for a, x in enumerate(c)):
                    raise InvalidValue(
                        f"structure.members[{i}]",
                        f"member {m.name!r} reaches {c}, outside {box}",
                    )

    def _check_displacement_probes_on_members(self) -> None:
        """A displacement probe lies within DISPLACEMENT_PROBE_TOLERANCE x the member's extent of
        its member (the value is the member's displacement at the nearest point of it)."""
        by_name = {m.name: m for m in self.structure.members}
        for i, p in enumerate(self.probes):
            if p.kind != "displacement" or p.target not in by_name:
                continue
            m = by_name[p.target]
            gap = distance_to_member(m, p.position)
            allowed = DISPLACEMENT_PROBE_TOLERANCE * m.extent
            if gap > allowed:
                raise InvalidValue(
                    f"probes[{i}].position",
                    f"{gap:.4g} m from member {m.name!r}; allowed {allowed:.4g} m "
                    f"({DISPLACEMENT_PROBE_TOLERANCE:g} x its extent {m.extent:.4g} m)",
                    p.position,
                )
