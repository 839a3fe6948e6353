"""Builders of [structure] sections shared by the structure tests (imported by module name)."""

import copy

from mpsfem.scenario.structure import StructureSection

BEAM = {
    "name": "wall",
    "type": "beam",
    "start": [0.0, 0.0],
    "end": [0.0, 0.25],
    "elements": 10,
    "bc": ["clamped", "simply_supported"],
    "material": {"youngs_modulus": 35e6, "density": 1100.0},
    "thickness": 0.04,
    "rayleigh_a2": 2e-4,
}

PLATE = {
    "name": "deck",
    "type": "plate",
    "element": "bfs",
    "origin": [0.12, 0.0, 0.1254],
    "size": [0.3, 0.15],
    "divisions": [8, 4],
    "bc": "clamped",
    "material": {"youngs_modulus": 50e6, "poisson_ratio": 0.3, "density": 1800.0},
    "thickness": 0.001,
    "geometric_thickness": 0.015,
}


def section(members, **kw):
    data = {"members": copy.deepcopy(members), "time": {"dt": 1e-4}}
    data.update(copy.deepcopy(kw))
    return StructureSection.model_validate(data)


# --------------------------------------------------------------------------- scenario files
def root_model():
    """The root scenario model with a [structure] section.

    The lead's Scenario gets a `structure` field when the sections are composed; until then the
    tests compose the same sections here.
    """
    from pydantic import Field

    from mpsfem.scenario.base import Section
    from mpsfem.scenario.output import OutputSection, RunSection
    from mpsfem.scenario.probes import Probe
    from mpsfem.scenario.schema import Scenario
    from mpsfem.scenario.structure import StructureSection

    if "structure" in Scenario.model_fields:
        return Scenario

    class StructureScenario(Section):
        title: str = ""
        run: RunSection
        output: OutputSection = Field(default_factory=OutputSection)
        structure: StructureSection | None = None
        probes: list[Probe] = Field(default_factory=list)

    return StructureScenario


def load(path, overrides=()):
    """Load a scenario file like mpsfem.scenario.loader.load_scenario, with a [structure] section."""
    import tomllib
    from pathlib import Path

    from mpsfem.scenario.loader import LoadedScenario, apply_override, parse_override

    model = root_model()
    path = Path(path)
    text = path.read_text()
    data = tomllib.loads(text)
    for item in overrides:
        apply_override(data, *parse_override(item))
    return LoadedScenario(
        scenario=model.model_validate(data), text=text, overrides=list(overrides), path=path
    )
