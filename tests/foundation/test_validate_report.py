"""``mpsfem validate`` ends with a summary and a verdict (issue 22): particle counts by kind,
memory and run-time estimates, contact problems between members and walls; --full adds the
resolved scenario."""

from __future__ import annotations

import json
from pathlib import Path

from mpsfem.cli import main

ROOT = Path(__file__).resolve().parents[2]
OBSTACLE = str(ROOT / "scenarios" / "dam_break_elastic_obstacle_2d.toml")


def validate(capsys, *args: str) -> str:
    assert main(["validate", *args]) == 0
    return capsys.readouterr().out


def test_summary_and_verdict(capsys):
    out = validate(capsys, str(ROOT / "scenarios" / "dam_break_2d.toml"))
    lines = out.strip().splitlines()
    assert lines[0] == "particles: 3200 fluid, 382 wall, 1568 dummy (5150 in all)"
    assert lines[1].startswith("memory: about 10 MiB")
    assert lines[2].startswith("run time: about ") and "on one thread" in lines[2]
    assert lines[-1].startswith("valid: Dam break") and lines[-1].endswith("no contact problems")
    assert not out.lstrip().startswith("{")  # the dump only with --full


def test_full_prints_the_resolved_scenario_first(capsys):
    out = validate(capsys, OBSTACLE, "--full")
    dump = out[: out.index("\nparticles:")]
    assert json.loads(dump)["structure"]["members"][0]["name"] == "obstacle"


def test_free_end_near_a_wall_is_a_contact_problem(capsys):
    # the plate's tip 0.005 m under the tank's top: 1.4 spacings minus half a spacing of cap
    out = validate(capsys, OBSTACLE, "--set", "structure.members.0.end=[0.292, 0.995]")
    warn = [x for x in out.splitlines() if x.startswith("warning:")]
    assert len(warn) == 1 and "free end is" in warn[0] and "fluid.walls[0]" in warn[0]
    assert out.strip().splitlines()[-1].endswith("1 warning(s)")


def test_member_through_a_wall_is_a_contact_problem(capsys):
    sets = [
        "structure.members.0.start=[0.5, 0.05]",
        "structure.members.0.end=[0.7, 0.05]",
        "probes.0.position=[0.6, 0.05]",
    ]
    out = validate(capsys, OBSTACLE, *[a for s in sets for a in ("--set", s)])
    assert "meets fluid.walls[0]: part of its mid-line lies inside the wall" in out


def test_structure_line_gives_each_members_mass_ratio(capsys):
    """(rho_s h) / (rho_w H) = 2500 x 0.012 / (1000 x 0.292) = 0.1027 for the obstacle, the
    ratio docs/coupler.md's light-member guide is indexed by."""
    out = validate(capsys, OBSTACLE)
    line = next(x for x in out.splitlines() if x.startswith("structure:"))
    assert (
        line
        == "structure: 1 member(s); mass ratio (rho_s h) / (rho_w H), H = 0.292 m: obstacle 0.103"
    )
