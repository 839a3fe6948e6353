"""Bad scenario input (issue 22): every fault is named before any compute, nothing crashes.

Each case once ended in a traceback (UnicodeDecodeError, RecursionError, OverflowError, a
division by zero at run time) or was accepted and then allocated petabytes, ran for ever or ran
wrong. Now each is refused by ``mpsfem validate`` as ``error: <key> = <value>: <what is allowed>``.
"""

from pathlib import Path

import pytest

from mpsfem.cli import main
from mpsfem.scenario.loader import load_scenario

SCENARIOS = Path(__file__).resolve().parents[2] / "scenarios"
DAM = SCENARIOS / "dam_break_2d.toml"
GREEN = SCENARIOS / "green_water_2d.toml"
SOLITARY = SCENARIOS / "solitary_wave_2d.toml"
CANTILEVER = SCENARIOS / "structure_cantilever_demo.toml"


def refused(capsys, path: Path, *overrides: str) -> str:
    """The one-line-per-problem error of ``mpsfem validate path --set ...`` (exit 2)."""
    argv = ["validate", str(path)]
    for item in overrides:
        argv += ["--set", item]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: invalid scenario") and "Traceback" not in err
    return err


def test_non_utf8_file_names_line_and_column(tmp_path, capsys):
    bad = tmp_path / "bad.toml"
    bad.write_bytes(b'title = "ok"\nx = "\xff\xfe"\n')
    err = refused(capsys, bad)
    assert "byte b'\\xff' at line 2, column 6 is not UTF-8" in err


@pytest.mark.parametrize(
    "text",
    ["a = " + "[" * 500 + "]" * 500, "a = " + "{b = " * 500 + "1" + "}" * 500],
    ids=["arrays", "inline tables"],
)
def test_nesting_500_deep_is_refused(tmp_path, capsys, text):
    deep = tmp_path / "deep.toml"
    deep.write_text(text)
    assert "nested too deep; at most 32 levels" in refused(capsys, deep)


def test_nesting_40_deep_names_the_key(tmp_path, capsys):
    deep = tmp_path / "deep.toml"
    deep.write_text("a = " + "[" * 40 + "]" * 40)
    assert "a[0][0]" in refused(capsys, deep)


def test_deep_set_value_is_refused(capsys):
    err = refused(capsys, DAM, "fluid.x=" + "[" * 600 + "]" * 600)
    assert "--set fluid.x: the value is nested too deep" in err


@pytest.mark.parametrize("path", [GREEN, DAM], ids=["green_water", "dam_break"])
def test_denormal_spacing_is_refused(capsys, path):
    err = refused(capsys, path, "fluid.spacing=5e-324")
    assert "fluid.spacing = 5e-324: must be >= 1e-06" in err


def test_denormal_courant_names_its_key(capsys):
    err = refused(capsys, DAM, "fluid.time_step.courant=5e-324")
    assert "fluid.time_step.courant = 5e-324: must be >= 0.0001" in err


def test_huge_domain_grid_names_the_domain(capsys):
    err = refused(capsys, DAM, "fluid.domain_lower=[-1e6, -1e6]", "fluid.domain_upper=[1e6, 1e6]")
    assert "fluid.domain_lower/domain_upper: the scene needs an estimated" in err
    assert "neighbour-grid cells" in err


def test_our_wording_and_did_you_mean(capsys):
    err = refused(capsys, DAM, "fluid.spacin=0.01", "fluid.pressure.tol=2.0", "fluid.dim=4")
    assert "fluid.spacin: unknown key; allowed here: blocks," in err
    assert "walls; did you mean 'spacing'?" in err
    assert "fluid.pressure.tol = 2.0: must be < 1.0" in err
    assert "fluid.dim = 4: must be one of 2 or 3" in err
    assert "Input should" not in err


@pytest.mark.parametrize(
    "override, expect",
    [
        ("fluid.walls.0.upper.0=1e15", "fluid.walls[0].upper[0] = 1000000000000000.0: must be <="),
        ("fluid.walls.0.upper.1=1e20", "fluid.walls[0].upper[1] = 1e+20: must be <="),
        ("fluid.walls.0.upper.1=1e6", "fluid.walls[0]: the scene needs an estimated"),
        ("fluid.spacing=1e-5", "fluid.blocks[0]: the scene needs an estimated"),
        ('probes.0.name="."', "probes[0].name = '.': must not be only dots"),
        ('probes.0.name=".."', "probes[0].name = '..': must not be only dots"),
        ("fluid.viscosity=1e3", "fluid.viscosity = 1000.0: limits the time step"),
    ],
)
def test_dam_break_overrides_refused_before_compute(capsys, override, expect):
    assert expect in refused(capsys, DAM, override)


def test_memory_refusal_names_spacing_and_limit(capsys, monkeypatch):
    monkeypatch.setenv("MPSFEM_MEMORY_LIMIT_GIB", "1")
    err = refused(capsys, DAM, "fluid.spacing=1e-4")
    assert "more than the memory limit 1 GiB (MPSFEM_MEMORY_LIMIT_GIB = 1)" in err
    assert "fluid.spacing = 0.0001" in err


def test_memory_limit_key_wins_over_the_environment(monkeypatch):
    monkeypatch.setenv("MPSFEM_MEMORY_LIMIT_GIB", "0.0001")
    load_scenario(DAM, ["run.memory_limit_gib=1.0"])  # the key raises the limit again


def test_bad_memory_limit_env_is_named(capsys, monkeypatch):
    monkeypatch.setenv("MPSFEM_MEMORY_LIMIT_GIB", "lots")
    assert "MPSFEM_MEMORY_LIMIT_GIB = 'lots'" in refused(capsys, DAM)


@pytest.mark.parametrize(
    "override, expect",
    [
        ("structure.time.dt=1e-300", "structure.time.dt = 1e-300: with run.end_time = 2.0 s makes"),
        ("structure.members.0.end.0=1e300", "structure.members[0] = [1e+300, 0.0]: every coord"),
        ("structure.members.0.elements=123456789", "structure.members[0]: the scene needs"),
        ("structure.members.0.rayleigh_a1=1e300", "structure.members[0].rayleigh_a1 = 1e+300"),
        ("structure.members.0.rayleigh_a2=1e300", "structure.members[0].rayleigh_a2 = 1e+300"),
    ],
)
def test_structure_overrides_refused_before_compute(capsys, override, expect):
    assert expect in refused(capsys, CANTILEVER, override)


def test_structure_command_refuses_too(capsys, tmp_path):
    argv = ["structure", str(CANTILEVER), "--out", str(tmp_path / "s.h5")]
    assert main([*argv, "--set", "structure.time.dt=1e-300"]) == 2
    assert "structure.time.dt = 1e-300" in capsys.readouterr().err
    assert not (tmp_path / "s.h5").exists()


def test_huge_direction_is_normalised():
    sc = load_scenario(SOLITARY, ["fluid.walls.1.motion.direction=[1e200, 0.0]"]).scenario
    assert sc.fluid.walls[1].motion.direction == [1.0, 0.0]


def test_zero_direction_is_refused(capsys):
    err = refused(capsys, SOLITARY, "fluid.walls.1.motion.direction=[0.0, 0.0]")
    assert "fluid.walls[1].motion.direction = [0.0, 0.0]: must not be the zero vector" in err


def test_end_time_option_is_held_to_the_structure_step_limit(capsys, tmp_path):
    coupled = SCENARIOS / "green_water_elastic_2d.toml"
    argv = ["run", str(coupled), "--end-time", "1e300", "--out", str(tmp_path / "r.h5")]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "--end-time = 1e+300: with structure.time.dt =" in err and "structure steps" in err
    assert not (tmp_path / "r.h5").exists()


def test_huge_domain_coordinates_are_refused_by_key(capsys):
    err = refused(capsys, DAM, "fluid.domain_upper=[1e67, 1e67]")
    assert "fluid.domain_upper[0] = 1e+67: must be <= 1000000.0" in err


@pytest.mark.parametrize(
    "override, expect",
    [
        ("fluid.gravity=[0.0, -1e300]", "fluid.gravity[1] = -1e+300: must be >= -1000.0"),
        (
            "fluid.blocks.0.velocity=[1e300, 0.0]",
            "fluid.blocks[0].velocity[0] = 1e+300: must be <=",
        ),
        ("fluid.density=1e300", "fluid.density = 1e+300: must be <= 100000.0"),
        ("fluid.density=5e-324", "fluid.density = 5e-324: must be >= 0.001"),
    ],
)
def test_physics_that_overflowed_at_the_first_step_is_refused(capsys, override, expect):
    """Each ran into 'float division by zero', a NaN residual or NaN positions at t = 0."""
    assert expect in refused(capsys, DAM, override)


def test_motion_period_and_amplitude_are_bounded(capsys):
    err = refused(
        capsys,
        SOLITARY,
        'fluid.walls.1.motion={kind = "harmonic", amplitude = 1e300, period = 5e-324}',
    )
    assert "fluid.walls[1].motion.amplitude = 1e+300: must be <= 1000000.0" in err
    assert "fluid.walls[1].motion.period = 5e-324: must be >= 1e-06" in err
