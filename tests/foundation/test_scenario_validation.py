"""Scenario validation: every problem names the dotted key, the value given and what is allowed."""

from pathlib import Path

import pytest

from mpsfem.scenario.base import ScenarioError
from mpsfem.scenario.loader import load_scenario, load_scenario_text

SCENARIOS = Path(__file__).resolve().parents[2] / "scenarios"

BASE = """
[run]
end_time = 1.0
[fluid]
spacing = 0.01
[[fluid.blocks]]
lower = [0.0, 0.0]
upper = [0.2, 0.4]
[[fluid.walls]]
name = "tank"
shape = "tank"
lower = [0.0, 0.0]
upper = [0.5, 1.0]
[[probes]]
name = "g"
kind = "pressure"
position = [0.1, 0.05]
"""


def problems(text: str, overrides=()) -> list[str]:
    with pytest.raises(ScenarioError) as info:
        load_scenario_text(text, overrides)
    return info.value.problems


@pytest.mark.parametrize("path", sorted(SCENARIOS.glob("*.toml")), ids=lambda p: p.name)
def test_shipped_scenarios_validate(path):
    load_scenario(path)


def test_base_is_valid():
    sc = load_scenario_text(BASE).scenario
    assert sc.fluid.spacing == 0.01
    assert sc.fluid.pressure.gamma == 0.01  # default within 0.01-0.05


def test_negative_spacing_names_key_value_and_rule():
    (msg,) = problems(BASE, ["fluid.spacing=-0.1"])
    assert msg.startswith("fluid.spacing = -0.1")
    assert msg == "fluid.spacing = -0.1: must be >= 1e-06"


def test_gamma_out_of_range():
    (msg,) = problems(BASE, ["fluid.pressure.gamma=1.5"])
    assert msg == "fluid.pressure.gamma = 1.5: must be <= 1.0"


def test_unknown_key_lists_allowed_keys():
    (msg,) = problems(BASE.replace("spacing = 0.01", "spacing = 0.01\nspaceing = 2"))
    assert msg.startswith("fluid.spaceing: unknown key")
    assert "spacing" in msg.split("allowed here:")[1]


def test_wrong_type():
    (msg,) = problems(BASE, ['fluid.spacing="small"'])
    assert "fluid.spacing = 'small'" in msg and "number" in msg


def test_bad_choice_lists_allowed_names():
    (msg,) = problems(BASE, ['fluid.pressure.solver="amg"'])
    assert "fluid.pressure.solver = 'amg'" in msg and "'pcg_amg'" in msg


def test_fluid_outside_tank():
    (msg,) = problems(BASE, ["fluid.blocks.0.upper=[0.7, 0.4]"])
    assert "blocks[0]" in msg and "outside the tank" in msg


def test_set_needs_toml_literal():
    (msg,) = problems(BASE, ["fluid.pressure.solver=pcg amg"])
    assert "not a TOML literal" in msg and "fluid.pressure.solver" in msg
    assert "bare word" in msg


def test_set_bare_word_is_a_string():
    """A shell strips the quotes of --set key="name": the bare word is taken as that string,
    while true/false/inf/nan stay TOML literals (and a bad name is still refused by the schema)."""
    sc = load_scenario_text(
        BASE, ["fluid.pressure.solver=pcg_jacobi", "probes.0.name=gauge-2.a", "run.progress=false"]
    ).scenario
    assert sc.fluid.pressure.solver == "pcg_jacobi"
    assert sc.probes[0].name == "gauge-2.a"
    assert sc.run.progress is False
    sc = load_scenario_text(BASE, ['fluid.pressure.solver="direct"']).scenario
    assert sc.fluid.pressure.solver == "direct"
    (msg,) = problems(BASE, ["fluid.pressure.solver=amg"])
    assert msg.startswith("fluid.pressure.solver = 'amg'") and "'pcg_amg'" in msg


def test_set_bad_index():
    (msg,) = problems(BASE, ["probes.3.radius=0.1"])
    assert "probes has no item 3" in msg


def test_set_applies_and_validates_lists():
    sc = load_scenario_text(BASE, ["probes.0.position=[0.15, 0.1]", "run.end_time=2"]).scenario
    assert sc.probes[0].position == [0.15, 0.1]
    assert sc.run.end_time == 2.0


def test_probe_dimension_checked():
    (msg,) = problems(BASE, ["probes.0.position=[0.1]"])
    assert "probes[0].position" in msg and "2 components" in msg


def test_probe_error_path_has_no_union_tag():
    (msg,) = problems(BASE, ["probes.0.radius=-1.0"])
    assert msg.startswith("probes[0].radius = -1.0")


def test_all_problems_reported_at_once():
    msgs = problems(BASE, ["fluid.spacing=-1", "fluid.density=0", "run.end_time=0"])
    keys = sorted(m.split(" ")[0] for m in msgs)
    assert keys == ["fluid.density", "fluid.spacing", "run.end_time"]


def test_missing_required_key():
    (msg,) = problems(BASE.replace("end_time = 1.0", ""))
    assert msg == "run.end_time: required key is missing"


def test_wave_gauge_half_width_only_with_top_particle():
    gauge = '[[probes]]\nname = "w"\nkind = "wave_gauge"\nposition = [0.1]\nhalf_width = 0.02\n'
    (msg,) = problems(BASE + gauge)
    assert msg.startswith("probes[1]") and "half_width = 0.02" in msg and "top_particle" in msg
    load_scenario_text(BASE + gauge + 'method = "top_particle"\n')


def test_box_wall_thinner_than_two_spacings_is_refused():
    box = '[[fluid.walls]]\nshape = "box"\nlower = [0.3, 0.2]\nupper = [0.4, 0.215]\n'
    (msg,) = problems(BASE + box)
    assert msg.startswith("fluid.walls[1].upper = [0.4, 0.215]: ")
    assert "0.015 m thick along axis 1" in msg and "2 spacings" in msg
    load_scenario_text(BASE + box.replace("0.215", "0.22"))


def test_motion_direction_dimension_checked():
    """A 2D direction on a wall of a 2D scene is fine; a 3-component one is refused with the key,
    the value and the allowed size (and a wall without motion needs none in 3D: default +x)."""
    load_scenario_text(BASE, ["fluid.walls.0.motion={kind = 'harmonic', direction = [0.0, 1.0]}"])
    (msg,) = problems(
        BASE, ["fluid.walls.0.motion={kind = 'harmonic', direction = [0.0, 0.0, 1.0]}"]
    )
    assert "walls[0].motion.direction" in msg and "[0.0, 0.0, 1.0]" in msg and "2 components" in msg


@pytest.mark.parametrize(
    ("override", "key"),
    [
        ("run.end_time=inf", "run.end_time = inf"),
        ("fluid.time_step.dt_max=inf", "fluid.time_step.dt_max = inf"),
        ("fluid.gravity=[0.0, nan]", "fluid.gravity[1] = nan"),
        ("fluid.walls.0.upper=[0.5, inf]", "fluid.walls[0].upper[1] = inf"),
        ("probes.0.position=[nan, 0.05]", "probes[0].position[0] = nan"),
    ],
)
def test_inf_and_nan_are_refused(override, key):
    (msg,) = problems(BASE, [override])
    assert msg.startswith(key) and "finite number" in msg


@pytest.mark.parametrize("end_time", ["inf", "nan", "0"])
def test_cli_end_time_must_be_finite_and_positive(tmp_path, capsys, end_time):
    from mpsfem.cli import main

    scen = tmp_path / "s.toml"
    scen.write_text(BASE)
    out = tmp_path / "r.h5"
    assert main(["run", str(scen), "--out", str(out), "--end-time", end_time]) == 2
    err = capsys.readouterr().err
    assert f"--end-time = {float(end_time)}: must be a finite number > 0" in err
    assert not out.exists()


STRUCTURE_2D = """
[run]
end_time = 1.0
[structure.time]
dt = 1e-4
[[structure.members]]
name = "wall"
type = "beam"
start = [0.0, 0.0]
end = [0.0, 0.3]
elements = 4
bc = "clamped"
thickness = 0.01
material = { youngs_modulus = 1e9, density = 1000.0 }
[[probes]]
name = "tip"
kind = "displacement"
target = "wall"
position = [0.0, 0.3]
"""

PLATE_3D = """
[run]
end_time = 1.0
[structure.time]
dt = 1e-4
[[structure.members]]
name = "deck"
type = "plate"
element = "bfs"
origin = [0.0, 0.0, 0.1]
size = [0.5, 0.25]
divisions = [4, 2]
bc = "clamped"
thickness = 0.01
material = { youngs_modulus = 1e9, density = 1000.0, poisson_ratio = 0.3 }
"""


@pytest.mark.parametrize(
    ("text", "overrides", "expect"),
    [
        (
            BASE,
            ["fluid.blocks.0.upper=[0.1, 0.0]"],
            "fluid.blocks[0].upper = [0.1, 0.0]: must exceed",
        ),
        (
            BASE + '[[probes]]\nname = "g"\nkind = "front"\n',
            [],
            "probes[1].name = 'g': probe names must be unique; probes[0] has it too",
        ),
        (
            BASE + '[[probes]]\nname = "f"\nkind = "force"\ntarget = "lid"\n',
            [],
            "probes[1].target = 'lid': names no wall patch or structure member; have ['tank']",
        ),
        (
            BASE,
            ["fluid.surface.beta_low=0.98"],
            "fluid.surface.beta_low = 0.98: must be below beta = 0.97",
        ),
        (
            BASE,
            ["fluid.walls.0.upper=[0.5]"],
            "fluid.walls[0].upper = [0.5]: must have as many entries as lower = [0.0, 0.0] (2)",
        ),
        (
            STRUCTURE_2D,
            ["structure.members.0.end=[0.0, 0.0]"],
            "structure.members[0].end = [0.0, 0.0]: `start` and `end` must be distinct points",
        ),
        (
            PLATE_3D,
            ["structure.members.0.bc=['clamped', 'free']"],
            "structure.members[0].bc = ['clamped', 'free']: a list `bc` needs one entry per edge "
            "(4 for this rectangle)",
        ),
        (
            STRUCTURE_2D,
            ["structure.gravity=[0.0, 0.0, -9.81]"],
            "structure.gravity = [0.0, 0.0, -9.81]: `gravity` needs 2 components in a 2D scene",
        ),
    ],
)
def test_table_checks_name_the_key_inside_the_table(text, overrides, expect):
    """A check across keys of a table names the offending key and its value, never a dump of
    the whole table (or of the whole scenario)."""
    msgs = problems(text, overrides)
    assert any(m.startswith(expect) for m in msgs), msgs
    assert not any("{" in m for m in msgs), msgs


def test_whole_scenario_check_prints_no_dump():
    (msg,) = problems("[run]\nend_time = 1.0\n")
    assert msg == "(top level): a scenario needs a [fluid] or a [structure] section (or both)"


@pytest.mark.parametrize(
    ("overrides", "expect"),
    [
        (
            ["fluid.domain_lower=[0.0, 0.0, 0.0]"],
            "fluid.domain_lower = [0.0, 0.0, 0.0]: must have 2",
        ),
        (["fluid.domain_upper=[1.0]"], "fluid.domain_upper = [1.0]: must have 2 components"),
        (
            ["fluid.domain_lower=[-0.1, 0.0]", "fluid.domain_upper=[0.6, 0.0]"],
            "fluid.domain_upper = [0.6, 0.0]: must exceed domain_lower = [-0.1, 0.0] in every "
            "axis (axis 1)",
        ),
        (["fluid.blocks.0.velocity=[1.0]"], "fluid.blocks[0].velocity = [1.0]: must have 2"),
        (
            ["fluid.time_step.dt_min=1e-2"],
            "fluid.time_step.dt_min = 0.01: must be <= dt_max = 0.001",
        ),
        (
            ["fluid.time_step.dt_initial=1e-2"],
            "fluid.time_step.dt_initial = 0.01: must lie in [dt_min, dt_max] = [1e-08, 0.001]",
        ),
        (
            ["fluid.time_step.dt_initial=1e-9"],
            "fluid.time_step.dt_initial = 1e-09: must lie in [dt_min, dt_max]",
        ),
        (
            ["fluid.domain_lower=[-0.1, -0.1]", "fluid.domain_upper=[0.15, 1.5]"],
            "fluid.domain_upper = [0.15, 1.5]: leaves fluid.blocks[0] ([0.0, 0.0] .. [0.2, 0.4]) "
            "partly outside the domain",
        ),
        (
            ["fluid.domain_lower=[0.05, -0.1]"],
            "fluid.domain_lower = [0.05, -0.1]: leaves fluid.blocks[0]",
        ),
        (
            [
                "fluid.sponges=[{start = 0.3, end = 0.5, coefficient = 600.0}, "
                "{start = 0.2, end = 0.0, coefficient = 600.0}]"
            ],
            "fluid.time_step.dt_max = 0.001: times the summed sponge coefficients 1200 1/s is 1.2",
        ),
    ],
)
def test_lengths_and_orderings_are_checked(overrides, expect):
    (msg,) = problems(BASE, overrides)
    assert msg.startswith(expect), msg


def test_consistent_lengths_and_orderings_pass():
    sc = load_scenario_text(
        BASE,
        [
            "fluid.domain_lower=[-0.1, -0.1]",
            "fluid.domain_upper=[0.6, 1.5]",
            "fluid.blocks.0.velocity=[0.5, 0.0]",
            "fluid.time_step.dt_initial=1e-4",
        ],
    ).scenario
    assert sc.fluid.time_step.dt_initial == 1e-4


def test_structure_only_probe_positions_have_the_structure_dimension():
    load_scenario_text(STRUCTURE_2D)
    (msg,) = problems(STRUCTURE_2D, ["probes.0.position=[0.0, 0.3, 0.0]"])
    assert msg.startswith("probes[0].position = [0.0, 0.3, 0.0]: must have 2 components"), msg
    plate_probe = '[[probes]]\nname = "mid"\nkind = "displacement"\ntarget = "deck"\n'
    load_scenario_text(PLATE_3D + plate_probe + "position = [0.25, 0.1, 0.1]\n")
    (msg,) = problems(PLATE_3D + plate_probe + "position = [0.25, 0.1]\n")
    assert msg.startswith("probes[0].position = [0.25, 0.1]: must have 3 components"), msg


def test_fluid_probe_outside_the_domain_is_refused():
    # default domain: blocks and walls (0..0.5, 0..1) grown by 10 l0 = 0.1 m, 1 m more upwards
    load_scenario_text(BASE, ["probes.0.position=[0.55, 1.9]"])
    (msg,) = problems(BASE, ["probes.0.position=[0.65, 0.05]"])
    assert msg.startswith("probes[0].position = [0.65, 0.05]: lies outside the fluid domain")
    assert "[-0.1, -0.1] .. [0.6, 2.1]" in msg
    gauge = '[[probes]]\nname = "w"\nkind = "wave_gauge"\nposition = [0.7]\n'
    (msg,) = problems(BASE + gauge)
    assert msg.startswith("probes[1].position = [0.7]: lies outside the fluid domain"), msg
    load_scenario_text(BASE + gauge.replace("0.7", "0.4"))


COUPLED = BASE + STRUCTURE_2D.replace("[run]\nend_time = 1.0\n", "").replace(
    "start = [0.0, 0.0]", "start = [0.3, 0.0]"
).replace("end = [0.0, 0.3]", "end = [0.3, 0.3]").replace('name = "tip"', 'name = "tip_d"').replace(
    "position = [0.0, 0.3]", "position = [0.3, 0.3]"
)


def test_member_outside_an_explicit_fluid_domain_is_refused():
    load_scenario_text(COUPLED)
    box = ["fluid.domain_lower=[-0.1, -0.1]", "fluid.domain_upper=[0.25, 1.5]"]  # holds the block
    (msg,) = problems(COUPLED, box)
    assert msg.startswith("structure.members[0]: member 'wall' reaches [0.3, "), msg


@pytest.mark.parametrize(
    ("position", "ok"),
    [([0.3, 0.32], True), ([0.3, 0.25], True), ([0.32, 0.1], True), ([0.3, 0.4], False)],
)
def test_displacement_probe_far_from_its_member_is_refused(position, ok):
    """Allowed: within 10 % of the member's length (0.3 m: 0.03 m) of its mid-line segment."""
    sets = [f"probes.1.position={position}"]
    if ok:
        load_scenario_text(COUPLED, sets)
        return
    (msg,) = problems(COUPLED, sets)
    assert msg.startswith(f"probes[1].position = {position}: 0.1 m from member 'wall'"), msg
    assert "allowed 0.03 m (0.1 x its extent 0.3 m)" in msg


def test_plate_displacement_probe_distance():
    probe = '[[probes]]\nname = "mid"\nkind = "displacement"\ntarget = "deck"\n'
    load_scenario_text(PLATE_3D + probe + "position = [0.25, 0.1, 0.12]\n")
    (msg,) = problems(PLATE_3D + probe + "position = [0.25, 0.4, 0.1]\n")
    assert msg.startswith("probes[0].position = [0.25, 0.4, 0.1]: 0.15 m from member 'deck'")


def test_gravity_defaults_along_the_last_axis():
    """Gravity left out points down the last axis: [0, -9.81] in 2D, [0, 0, -9.81] in 3D (a 3D
    scene without it was refused over a value the user never wrote)."""
    text = (SCENARIOS / "hydrostatic_3d.toml").read_text()
    assert "gravity = [0.0, 0.0, -9.81]" in text
    sc = load_scenario_text(text.replace("gravity = [0.0, 0.0, -9.81]", "")).scenario
    assert sc.fluid.gravity == [0.0, 0.0, -9.81]
    assert load_scenario_text(BASE).scenario.fluid.gravity == [0.0, -9.81]
