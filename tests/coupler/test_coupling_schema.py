"""The [coupling] scenario section: strict, closed, described, errors that say what is allowed."""

from __future__ import annotations

import typing
import warnings
from pathlib import Path

import pytest
from pydantic import BaseModel, ValidationError

from mpsfem.coupler import SCHEMES
from mpsfem.coupler.acceleration import ACCELERATIONS
from mpsfem.coupler.mapping import MAPPINGS
from mpsfem.coupler.transport import TRANSPORTS
from mpsfem.scenario.base import Section
from mpsfem.scenario.coupling import CouplingSection
from mpsfem.scenario.schema import AddedMassWarning, LinkWarning


def errors(data) -> list[str]:
    with pytest.raises(ValidationError) as e:
        CouplingSection.model_validate(data)
    return [f"{'.'.join(map(str, x['loc']))}: {x['msg']}" for x in e.value.errors()]


def models(root) -> set[type[BaseModel]]:
    out, todo = set(), [root]
    while todo:
        m = todo.pop()
        if m in out:
            continue
        out.add(m)
        for f in m.model_fields.values():
            stack = [f.annotation]
            while stack:
                a = stack.pop()
                if isinstance(a, type) and issubclass(a, BaseModel):
                    todo.append(a)
                stack.extend(typing.get_args(a))
    return out


def test_defaults():
    c = CouplingSection()
    assert c.scheme == "implicit" and c.window is None and c.force_sampling == "mean"
    assert c.mapping.kind == "shape-function" and c.acceleration.kind == "iqn-ils"
    assert c.transport.kind == "inproc" and c.transport.timeout_s == 10.0
    assert c.convergence.on_divergence == "stop"


def test_every_field_described_and_sections_closed():
    for m in models(CouplingSection):
        assert issubclass(m, Section), m
        assert m.model_config["extra"] == "forbid" and m.model_config["strict"]
        for name, f in m.model_fields.items():
            assert f.description, f"{m.__name__}.{name} has no description"


@pytest.mark.parametrize(
    "registry, key",
    [(MAPPINGS, "mapping"), (ACCELERATIONS, "acceleration"), (TRANSPORTS, "transport")],
)
def test_every_registered_component_is_a_kind(registry, key):
    for name in registry:
        c = CouplingSection.model_validate({key: {"kind": name}})
        assert getattr(c, key).kind == name


@pytest.mark.parametrize(
    "data, expect",
    [
        ({"scheme": "weak"}, "scheme: Value error, allowed: 'explicit', 'implicit'"),
        ({"mapping": {"kind": "nearest"}}, "'kfbi', 'conservative-kernel', 'shape-function'"),
        ({"acceleration": {"kind": "anderson"}}, "'constant', 'aitken', 'iqn-ils', 'iqn-imvj'"),
        ({"acceleration": {"kind": "iqn-imvj", "restart": "RS-X"}}, "'RS-SVD', 'RS-LS' or 'RS-0'"),
        (
            {"acceleration": {"kind": "iqn-ils", "preconditioner": "sum"}},
            "'none', 'value' or 'residual_sum'",
        ),
        ({"acceleration": {"kind": "iqn-ils", "data": ["velocity"]}}, 'start with "displacement"'),
        (
            {"acceleration": {"kind": "iqn-imvj", "complement_relaxation": 0.0}},
            "must be in (0, 1] or 'auto'",
        ),
        ({"transport": {"kind": "tcp"}}, "'inproc', 'mpi', 'zenoh'"),
        (
            {"acceleration": {"kind": "iqn-ils", "reuse": 2}},
            "reuse: Extra inputs are not permitted",
        ),
        ({"window": -1e-3}, "window: Input should be greater than 0"),
        ({"window": "1e-3"}, "window: Input should be a valid number"),
        ({"coupling": 1}, "coupling: Extra inputs are not permitted"),
        ({"acceleration": {"kind": "constant", "relaxation": 1.5}}, "less than or equal to 1"),
        ({"acceleration": {"kind": "iqn-ils", "filter": "QR3"}}, "'QR1', 'QR2' or 'none'"),
        ({"convergence": {"on_divergence": "ignore"}}, "'stop' or 'continue'"),
        ({"convergence": {"min_iterations": 4, "max_iterations": 3}}, "min_iterations = 4 must be"),
        ({"transport": {"kind": "zenoh", "endpoint": "127.0.0.1:7447"}}, "tcp/<host>:<port>"),
        ({"transport": {"kind": "zenoh", "endpoint": "tcp/127.0.0.1:70000"}}, "port 1..65535"),
        (
            {"transport": {"kind": "mpi", "timeout_s": 0}},
            "timeout_s: Input should be greater than 0",
        ),
        ({"mapping": {"kind": "kfbi", "kernel": "gauss"}}, "'improved' or 'original'"),
    ],
)
def test_bad_input_says_what_is_allowed(data, expect):
    msgs = errors(data)
    assert any(expect in m for m in msgs), msgs


def test_integer_accepted_for_float_and_toml_round_trip():
    import tomllib

    text = """
    scheme = "explicit"
    window = 1
    [mapping]
    kind = "kfbi"
    radius = 0.0042
    [acceleration]
    kind = "aitken"
    initial_relaxation = 1
    [transport]
    kind = "zenoh"
    endpoint = "tcp/127.0.0.1:7500"
    """
    c = CouplingSection.model_validate(tomllib.loads(text))
    assert c.window == 1.0 and c.mapping.radius == 0.0042 and c.transport.endpoint.endswith("7500")
    again = CouplingSection.model_validate(c.model_dump())
    assert again == c


def test_scheme_names_match_registry():
    for name in SCHEMES:
        assert CouplingSection(scheme=name).scheme == name


def test_corotational_members_turn_the_rigid_link_exactly_unless_told():
    from pathlib import Path

    from mpsfem.scenario.loader import load_scenario

    scene = Path(__file__).resolve().parents[2] / "scenarios" / "dam_break_elastic_obstacle_2d.toml"
    corot = "structure.members.0.kinematics=corotational"
    linear = "structure.members.0.kinematics=linear"
    assert not load_scenario(scene, [linear]).scenario.coupling.mapping.large_rotation
    assert load_scenario(scene, [corot]).scenario.coupling.mapping.large_rotation
    with pytest.warns(LinkWarning, match="'obstacle'.*linear rigid link"):
        told = load_scenario(scene, [corot, "coupling.mapping.large_rotation=false"])
    assert not told.scenario.coupling.mapping.large_rotation
    with warnings.catch_warnings():  # a linear member with the linear link: nothing to say
        warnings.simplefilter("error", LinkWarning)
        load_scenario(scene, [linear, "coupling.mapping.large_rotation=false"])


# --------------------------------------------------------------------------- light members
ROOT = Path(__file__).resolve().parents[2]
OBSTACLE = ROOT / "scenarios" / "dam_break_elastic_obstacle_2d.toml"
OBSTACLE_SPH = ROOT / "validation" / "results" / "delta_sph_obstacle.toml"
LIGHT = "structure.members.0.material.density=2.43"  # rho_s h / (rho_w H) = 1e-4


def _load_quietly(path, overrides=()):
    from mpsfem.scenario.loader import load_scenario

    with warnings.catch_warnings():
        warnings.simplefilter("error", AddedMassWarning)
        return load_scenario(path, list(overrides)).scenario


def test_mass_ratio_is_the_documented_one():
    """The obstacle's ratio as docs/validation_coupling_stress.md defines it: rho_s h = 2500 x
    0.012 kg/m^2 against 1000 kg/m^3 x the 0.292 m column: 0.1027."""
    sc = _load_quietly(OBSTACLE)
    assert sc.fluid.water_height == pytest.approx(0.292, rel=1e-12)
    ratio = sc.mass_ratios()["obstacle"]
    assert ratio == pytest.approx(2500 * 0.012 / (1000 * 0.292), rel=1e-12)


def test_shipped_scenarios_raise_no_light_member_warning():
    for path in sorted((ROOT / "scenarios").glob("*.toml")) + [OBSTACLE_SPH]:
        _load_quietly(path)


def test_a_light_member_under_mps_is_pointed_to_the_guide():
    from mpsfem.scenario.loader import load_scenario

    with pytest.warns(AddedMassWarning, match=r"'obstacle'.*= 0\.0001.*below 0\.01.*Light members"):
        load_scenario(OBSTACLE, [LIGHT])
    _load_quietly(OBSTACLE, [LIGHT, "structure.members.0.fictitious_mass=0.25"])


def test_a_light_member_under_delta_sph_is_pointed_to_the_safeguards():
    from mpsfem.scenario.loader import load_scenario

    with pytest.warns(AddedMassWarning, match=r"below 0\.001.*delta-sph.*safeguards"):
        load_scenario(OBSTACLE_SPH, [LIGHT])
    _load_quietly(OBSTACLE_SPH, [LIGHT, "coupling.convergence.accept_unconverged=best"])
    # 1e-3 is where δ-SPH's defaults still converged: no warning there
    _load_quietly(OBSTACLE_SPH, ["structure.members.0.material.density=25.0"])  # 1.03e-3


def test_a_light_member_under_delta_sph_in_long_windows_is_advised_on_the_window():
    """docs/fluid_sph.md, "The coupling window against c0 / l0": with the safeguards on, the
    obstacle at 1e-4 under δ-SPH (c0 = 33.8 m/s, l0 = 3.65 mm) in its 0.25 ms windows (2.3 l0 /
    c0) draws no warning; in 0.5 ms windows (4.6 l0 / c0) it is told the window and the bound
    3 l0 / c0 = 0.323 ms; a member at 1.03e-3 in the same windows is not."""
    from mpsfem.scenario.loader import load_scenario

    safe = [LIGHT, "coupling.convergence.accept_unconverged=best"]
    sc = _load_quietly(OBSTACLE_SPH, safe)
    assert sc.fluid.sph_sound_speed() == pytest.approx(33.8, abs=0.05)
    with pytest.warns(
        AddedMassWarning, match=r"'obstacle'.*window = 0\.0005 s = 4\.6 l0 / c0.*<= 0\.000323 s"
    ):
        load_scenario(OBSTACLE_SPH, [*safe, "coupling.window=5e-4"])
    _load_quietly(
        OBSTACLE_SPH, ["structure.members.0.material.density=25.0", "coupling.window=5e-4"]
    )
