"""``mpsfem validate`` for ``fluid.method = "delta-sph"``: the report's particle count, memory
and run-time estimate are δ-SPH's (explicit, dt from the artificial sound speed c0, RK4 = four
right-hand sides a step), not MPS's."""

from __future__ import annotations

import csv
import math
from pathlib import Path

import pytest

from mpsfem.cli import main
from mpsfem.fluid_sph.solver import DeltaSPHSolver
from mpsfem.scenario.limits import BYTES_PER_PARTICLE_DELTA_SPH, fluid_parts
from mpsfem.scenario.loader import load_scenario
from mpsfem.scenario_report import (
    COST_PER_PARTICLE_RHS,
    _delta_sph_time_estimate,
    report,
)

ROOT = Path(__file__).resolve().parents[2]
#: scenarios/dam_break_2d.toml under δ-SPH (validation/delta_sph_dam_break.py)
DAM = ROOT / "validation" / "results" / "delta_sph_dam_break.toml"
#: the δ-SPH dam break's measured steps (benchmarks/bench_delta_sph.py)
STEPS_CSV = ROOT / "benchmarks" / "results" / "delta_sph_vs_mps_steps.csv"


def measured_row() -> dict:
    with STEPS_CSV.open() as fh:
        rows = list(csv.DictReader(line for line in fh if not line.startswith("#")))
    return next(r for r in rows if r["method"] == "delta-sph")


def steps_of(sets: list[str]) -> int:
    sc = load_scenario(DAM, sets).scenario
    return _delta_sph_time_estimate(sc, 1)[0]


def test_report_names_delta_sph_and_counts_its_particles(capsys):
    assert main(["validate", str(DAM)]) == 0
    out = capsys.readouterr().out.splitlines()
    solver = DeltaSPHSolver(load_scenario(DAM).scenario.fluid)  # builds, takes no step
    assert out[0].endswith(f"({solver.n} in all)")
    assert out[1].endswith(f"({BYTES_PER_PARTICLE_DELTA_SPH[2]} B per particle, δ-SPH)")
    assert "δ-SPH, explicit: 4 right-hand side(s) a step (rk4)" in out[2]
    assert f"c0 = {solver.c0:.3g} m/s" in out[2]


def test_default_sound_speed_is_the_solvers():
    for sets in ([], ["fluid.sph.reference_speed=7.5"], ["fluid.blocks.0.upper=[0.146, 0.35]"]):
        sc = load_scenario(DAM, sets).scenario
        assert sc.fluid.sph_sound_speed() == DeltaSPHSolver(sc.fluid).c0


@pytest.mark.parametrize("c0", [40.0, 80.0, 160.0])
def test_steps_follow_the_sound_speed(c0):
    # dt = cfl h / (c0 + u): cfl 0.8 (rk4), h = 1.3 l0, u the free fall from 2L = 0.292 m
    h, u = 1.3 * 0.00365, math.sqrt(2.0 * 9.81 * 0.292)
    expected = math.ceil(0.27 * (c0 + u) / (0.8 * h))
    assert steps_of([f"fluid.sph.sound_speed={c0}"]) == expected


def test_leapfrog_costs_one_right_hand_side_a_step():
    sc = load_scenario(DAM, ["fluid.sph.integrator=symplectic", "fluid.sph.cfl=0.8"]).scenario
    steps, seconds, _ = _delta_sph_time_estimate(sc, 1000)
    assert seconds == pytest.approx(steps * 1000 * COST_PER_PARTICLE_RHS[2], rel=1e-12)
    sc4 = load_scenario(DAM, ["fluid.sph.cfl=0.8"]).scenario
    steps4, seconds4, _ = _delta_sph_time_estimate(sc4, 1000)
    assert steps4 == steps and seconds4 == pytest.approx(4.0 * seconds, rel=1e-12)


def test_steps_against_the_benchmarked_dam_break():
    # the estimate takes the largest speed from the start, so it errs a little on the long side
    row = measured_row()
    sim = float(row["sim_time_s"])
    estimate = steps_of([f"run.end_time={sim}"])
    assert 1.0 <= estimate / int(row["steps"]) <= 1.1


def test_run_time_against_the_benchmarked_dam_break():
    # one-thread CPU time per simulated second measured on this scene, 2D (the wall time on an
    # idle core; the shared machine's wall time varies with its load); the cost per particle
    # and RHS comes from another scene (still water), so within 30 %
    row = measured_row()
    sim = float(row["sim_time_s"])
    sc = load_scenario(DAM, [f"run.end_time={sim}"]).scenario
    r = report(sc)
    n = int(row["particles"])
    assert f"({n} in all)" in r.lines[0]
    _, seconds, _ = _delta_sph_time_estimate(sc, n)
    measured = float(row["cpu_s_per_sim_s"]) * sim
    assert seconds == pytest.approx(measured, rel=0.3)


def test_size_limit_estimates_delta_sph_layers_and_memory():
    # scenario/limits.py: wall layers filling 2h = 2.6 l0 (4 layers; MPS's largest r_e, 4.01 l0: 5),
    # δ-SPH's bytes per particle; the estimate errs on the large side of the built scene
    sc = load_scenario(DAM).scenario
    parts = {p.what: p for p in fluid_parts(sc.fluid)}
    built = DeltaSPHSolver(sc.fluid)
    assert parts["wall particles"].count >= built.n - built.n_fluid
    assert parts["fluid particles"].count >= built.n_fluid
    assert parts["wall particles"].bytes_each == BYTES_PER_PARTICLE_DELTA_SPH[2]
    mps = load_scenario(ROOT / "scenarios" / "dam_break_2d.toml").scenario
    mps_walls = next(p for p in fluid_parts(mps.fluid) if p.what == "wall particles")
    assert parts["wall particles"].count < mps_walls.count
