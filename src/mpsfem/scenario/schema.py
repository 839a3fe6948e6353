"""The root scenario model: one schema shared by every participant."""

from __future__ import annotations

from pydantic import Field, model_validator

from mpsfem.scenario.base import Section
from mpsfem.scenario.coupling import CouplingSection
from mpsfem.scenario.fluid import FluidSection
from mpsfem.scenario.output import OutputSection, RunSection
from mpsfem.scenario.probes import Probe
from mpsfem.scenario.structure import StructureSection


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

    @model_validator(mode="after")
    def _check(self) -> Scenario:
        names = [p.name for p in self.probes]
        dup = sorted({n for n in names if names.count(n) > 1})
        if dup:
            raise ValueError(f"probe names must be unique; repeated: {dup}")
        if self.fluid is not None:
            d = self.fluid.dim
            for i, p in enumerate(self.probes):
                pos = getattr(p, "position", None)
                want = d - 1 if p.kind == "wave_gauge" else d
                if pos is not None and len(pos) != want:
                    raise ValueError(f"probes[{i}].position {pos} must have {want} components")
                if p.kind == "front" and p.axis >= d:
                    raise ValueError(f"probes[{i}].axis {p.axis} must be < dim = {d}")
            walls = {w.name for w in self.fluid.walls if w.name}
            if self.structure is not None:
                walls |= {m.name for m in self.structure.members}
            for i, p in enumerate(self.probes):
                if p.kind == "force" and p.target not in walls:
                    raise ValueError(
                        f"probes[{i}].target '{p.target}' names no wall patch; have {sorted(walls)}"
                    )
        members = {m.name for m in self.structure.members} if self.structure else set()
        for i, p in enumerate(self.probes):
            if p.kind == "displacement" and p.target not in members:
                raise ValueError(
                    f"probes[{i}].target '{p.target}' names no structure member; have "
                    f"{sorted(members)}"
                )
            if p.kind == "energy" and p.target != "fluid" and p.target not in members:
                raise ValueError(
                    f"probes[{i}].target '{p.target}' must be 'fluid' or a structure member "
                    f"{sorted(members)}"
                )
        if self.coupling is not None and (self.fluid is None or self.structure is None):
            raise ValueError("[coupling] needs both a [fluid] and a [structure] section")
        if self.fluid is None and self.structure is None:
            raise ValueError("a scenario needs a [fluid] or a [structure] section (or both)")
        return self
