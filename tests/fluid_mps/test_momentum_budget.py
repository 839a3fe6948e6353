"""The fluid's momentum budget (fluid_mps/momentum_budget.py) and the momentum-exchange force.

References: exact identities of the discrete step, so the tolerances are round-off ones (sums
of O(100) terms of order the boundary impulse: 1e-9 relative):

- the pressure stage's momentum change is the sum of its pair terms: internal (fluid-fluid)
  plus the exchange with every boundary patch;
- an antisymmetric gradient (``tanaka``, ``cmps``) leaves no internal imbalance, so with the
  exchange force reported the budget closes to round-off;
- a collision of one fluid particle with a wall hands the wall m (1 + e) a along the normal.
"""

from __future__ import annotations

from pathlib import Path

import h5py
import numpy as np
import pytest

from mpsfem.coupler.coupling_scheme import create_scheme
from mpsfem.fluid_mps.collision import collide
from mpsfem.fluid_mps.momentum_budget import (
    booking_targets,
    collision_exchange,
    touches_boundary,
)
from mpsfem.fluid_mps.neighbours import build_neighbours
from mpsfem.fluid_mps.participant import FluidParticipant
from mpsfem.scenario.base import ScenarioError
from mpsfem.scenario.loader import load_scenario
from mpsfem.simulation import coupling_config, run_fluid
from mpsfem.structure_fem.participant import StructureParticipant

ROOT = Path(__file__).resolve().parents[2]
DAM = ROOT / "scenarios" / "dam_break_2d.toml"
PLATE = ROOT / "scenarios" / "hydrostatic_plate_2d.toml"
COARSE = [
    "fluid.spacing=0.0073",
    "output.snapshot_interval=0",
    "output.checkpoint_interval=0",
    "run.progress=false",
    "run.threads=1",
]


def budget_run(tmp_path: Path, name: str, extra: list[str], end: float = 0.04) -> dict:
    out = tmp_path / f"{name}.h5"
    run_fluid(load_scenario(DAM, [*COARSE, *extra]), out, end_time=end)
    with h5py.File(out, "r") as h5:
        g = h5["momentum_budget"]
        return {k: g[k][()] for k in g} | {"attrs": dict(g.attrs)}


def test_pressure_stage_is_the_sum_of_its_pair_terms(tmp_path):
    b = budget_run(tmp_path, "default", [])
    assert b["attrs"]["boundary_force"] == "pressure_and_contact"
    assert b["time"].shape == b["period"].shape and len(b["time"]) > 20  # one row per step
    total = b["pressure"].sum(axis=0)
    split = b["internal_pressure"].sum(axis=0) - b["patch_pressure"].sum(axis=(0, 1))
    assert np.allclose(split, total, rtol=1e-9, atol=1e-9 * np.abs(total).max())
    # every stage is booked: the momentum change is the sum of the stages and gravity
    stages = sum(b[k] for k in ("gravity", "sponge", "viscous", "collision", "pressure"))
    assert np.allclose(stages, b["momentum_change"], rtol=0, atol=1e-12)
    # the default gradient (C_i^-1, p_min) is not antisymmetric: an internal imbalance remains
    assert np.abs(b["internal_pressure"].sum(axis=0)).max() > 0.1 * np.abs(total).max()


@pytest.mark.parametrize("gradient", ["tanaka", "cmps"])
def test_conservative_gradient_closes_the_budget(tmp_path, gradient):
    b = budget_run(
        tmp_path,
        gradient,
        [f"fluid.pressure.gradient={gradient}", "fluid.boundary_force=momentum_exchange"],
    )
    impulse = np.abs(b["patch_reported"].sum(axis=0)).max()
    assert impulse > 1.0  # N s/m: the column pushes on the tank
    assert np.abs(b["internal_pressure"]).max() <= 1e-12 * impulse
    assert np.abs(b["residual"].sum(axis=0)).max() <= 1e-9 * impulse
    assert np.allclose(b["patch_reported"], b["patch_exchange"], rtol=0, atol=1e-12 * impulse)
    parts = b["patch_pressure"] + b["patch_viscous"] + b["patch_collision"]
    assert np.allclose(parts, b["patch_exchange"], rtol=0, atol=1e-12 * impulse)


def test_collision_ramp_keeps_the_budget_closed(tmp_path):
    """With the collision ramp (fluid.collision.ramp) the walls are booked the faded impulse
    the fluid loses: under the conservative gradient the budget still closes to round-off, and
    the collision stage differs from the hard threshold's."""
    sets = ["fluid.pressure.gradient=tanaka", "fluid.boundary_force=momentum_exchange"]
    b = budget_run(tmp_path, "ramp", [*sets, "fluid.collision.ramp=0.5"])
    hard = budget_run(tmp_path, "hard", sets)
    impulse = np.abs(b["patch_reported"].sum(axis=0)).max()
    assert np.abs(b["patch_collision"]).max() > 0.0
    assert np.abs(b["residual"].sum(axis=0)).max() <= 1e-9 * impulse
    assert not np.array_equal(b["collision"], hard["collision"])


def test_reported_force_models(tmp_path):
    """'pressure_and_contact' reports eq. 2-51 plus the viscous and collision exchange;
    'pressure_integral' eq. 2-51 alone (same run: the models only change what is reported in a
    fluid-only run)."""
    a = budget_run(tmp_path, "contact", [])
    b = budget_run(tmp_path, "integral", ["fluid.boundary_force=pressure_integral"])
    np.testing.assert_array_equal(a["fluid_momentum"], b["fluid_momentum"])
    contact = a["patch_viscous"] + a["patch_collision"]
    assert np.abs(a["patch_collision"]).max() > 0.0  # the collision model acts at the walls
    scale = np.abs(b["patch_reported"]).max()
    assert np.allclose(a["patch_reported"], b["patch_reported"] + contact, 0, 1e-12 * scale)


def test_exchange_needs_an_antisymmetric_gradient():
    with pytest.raises(ScenarioError, match=r"fluid\.boundary_force.*antisymmetric"):
        load_scenario(DAM, ["fluid.boundary_force=momentum_exchange"])


@pytest.mark.parametrize(
    "gap, ramp, share, rtol", [(0.004, 0.0, 1.0, 1e-15), (0.0045, 0.5, 0.2, 1e-12)]
)
def test_collision_impulse_on_a_wall(gap, ramp, share, rtol):
    """Fluid particle 0 approaches wall particle 1 at 2 m/s along x: e = 0.2 hands the wall
    m (1 + e) 2 m/s along +x (collision.py), booked on the wall particle's own row; with the
    ramp 0.5 at 0.0045 m of a 0.005 m distance the pair carries (0.005 - 0.0045) / 0.0025 =
    0.2 of it. Either way the wall is booked m times the fluid particle's velocity change."""
    pos = np.array([[0.0, 0.0], [gap, 0.0]])
    vel = np.array([[2.0, 0.0], [0.0, 0.0]])
    kind = np.array([0, 1], dtype=np.int8)
    nb = build_neighbours(pos, 0.01)
    visit = np.zeros(2, dtype=np.int8)
    touches_boundary(kind, nb.indptr, nb.indices, visit)
    assert visit.tolist() == [1, 0]
    target = booking_targets(kind, np.full(2, -1, dtype=np.int32))
    out = np.zeros((1, 2))
    mass = 0.25
    collision_exchange(pos, vel, kind, nb.indptr, nb.indices, 0.005, 0.2, visit, target, 1,
                       mass, out, ramp)  # fmt: skip
    np.testing.assert_allclose(out, [[mass * 1.2 * 2.0 * share, 0.0]], rtol=rtol)
    after = vel.copy()
    collide(pos, after, kind, nb.indptr, nb.indices, 0.005, 0.2, ramp=ramp)
    np.testing.assert_allclose(out[0], -mass * (after[0] - vel[0]), rtol=1e-12)


def test_dummies_are_booked_on_their_pressure_particle():
    kind = np.array([0, 1, 2, 2], dtype=np.int8)
    src = np.array([-1, -1, 1, -1], dtype=np.int32)
    assert booking_targets(kind, src).tolist() == [0, 1, 1, 3]


def test_structure_receives_the_momentum_the_fluid_loses_at_it():
    """Coupled hydrostatic plate, exchange force, conservative gradient: over 6 windows the
    impulse the structure is handed (the window means the coupler maps; the default
    shape-function mapping is a transpose one and keeps their total) equals the exchange impulse booked on the member's patches."""
    loaded = load_scenario(
        PLATE,
        [
            "fluid.spacing=0.05",
            "fluid.pressure.gradient=tanaka",
            "fluid.boundary_force=momentum_exchange",
        ],
    )
    sc = loaded.scenario
    structure = StructureParticipant(sc)
    fluid = FluidParticipant(sc.fluid, structure.interface(), member_names=["plate"])
    scheme = create_scheme(fluid, structure, coupling_config(sc))
    scheme.initialize()
    budget = fluid.solver.budget
    ids = [budget.names.index(n) for n in ("plate+", "plate-")]
    start = budget.patch_impulse[ids].sum(axis=0).copy()
    received = np.zeros(2)
    for _ in range(6):
        rec = scheme.advance_window()
        received += rec.window * scheme.F_s.sum(axis=0)  # the window's force, structure side
    booked = budget.patch_impulse[ids].sum(axis=0) - start
    assert abs(booked[1]) > 1e-3  # N s/m: the column's weight over 1.2 ms
    np.testing.assert_allclose(received, booked, rtol=1e-9, atol=1e-12)
