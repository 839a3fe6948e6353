"""The δ-SPH momentum budget (fluid_sph/momentum_budget.py): the split of every right-hand side,
weighted as the integrator weights it, explains the fluid's momentum change to round-off, and
an externally driven patch's exchange is the force the coupled participant reports."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from mpsfem.coupler.coupling_scheme import create_scheme
from mpsfem.fluid_methods import create_fluid_participant
from mpsfem.fluid_sph.solver import DeltaSPHSolver, NoBudget
from mpsfem.scenario.fluid import FluidSection
from mpsfem.scenario.loader import load_scenario
from mpsfem.structure_fem.participant import StructureParticipant

ROOT = Path(__file__).resolve().parents[2]
PLATE = ROOT / "scenarios" / "hydrostatic_plate_2d.toml"


def _dam(integrator: str, budget: bool = True) -> DeltaSPHSolver:
    """The Koshizuka-Oka column (scenarios/dam_break_2d.toml's geometry) at L/10: 10 x 20 fluid
    particles, a few dozen steps of the collapse on the floor and the left wall."""
    extra = {"momentum_budget": True} if budget else {}
    spec = FluidSection(
        method="delta-sph",
        spacing=0.0146,
        blocks=[{"lower": [0.0, 0.0], "upper": [0.146, 0.292]}],
        walls=[{"shape": "tank", "lower": [0.0, 0.0], "upper": [0.584, 0.4], "name": "tank"}],
        sph={"integrator": integrator},
        **extra,
    )
    return DeltaSPHSolver(spec)


@pytest.mark.parametrize("integrator", ["rk4", "symplectic"])
def test_budget_closes_to_round_off(integrator):
    """Per step: dP = G + (internal pressure) + (internal viscous) - sum_patches exchange, with
    dP from the velocities and the rest from the split; the residual is round-off (< 1e-10 of
    the largest boundary impulse), and the fluid-fluid pairs cancel to round-off too."""
    s = _dam(integrator)
    worst, biggest, internal = 0.0, 0.0, 0.0
    for _ in range(30):
        s.step(s.dt_next)
        b = s.budget.take(s.vel, s.kind)
        exchange = sum(b[f"{n}/exchange"] for n in s.budget.names)
        closure = (
            b["momentum_change"]
            - b["gravity"]
            - b["internal_pressure"]
            - b["internal_viscous"]
            + exchange
        )
        assert np.allclose(b["pressure"], b["internal_pressure"] - exchange, rtol=0, atol=1e-300)
        biggest = max(biggest, max(np.abs(b[f"{n}/exchange"]).max() for n in s.budget.names))
        worst = max(worst, np.abs(closure).max())
        internal = max(internal, np.abs(b["internal_pressure"]).max())
        internal = max(internal, np.abs(b["internal_viscous"]).max())
        assert not b["sponge"].any() and not b["collision"].any()
    assert biggest > 0.0
    assert worst < 1e-10 * biggest
    assert internal < 1e-10 * biggest
    # the walls do push: the exchange is far from round-off against the weight
    assert biggest > 1e-3 * np.abs(b["gravity"]).max()


def test_budget_over_many_steps_and_its_key():
    """One period over several steps is the sum of its steps (the ledger accumulates), the
    reported impulse is the pressure integral at the step ends, and the key's MPS default
    (true) leaves δ-SPH without a budget unless given."""
    assert isinstance(_dam("rk4", budget=False).budget, NoBudget)
    s = _dam("rk4")
    p0 = s.budget.take(s.vel, s.kind)["fluid_momentum"]
    reported = np.zeros(2)
    for _ in range(10):
        dt = s.dt_next
        s.step(dt)
        reported += dt * s.boundary_force(s.budget.names)
    b = s.budget.take(s.vel, s.kind)
    assert np.allclose(b["momentum_change"], b["fluid_momentum"] - p0, rtol=1e-14, atol=0)
    rep = sum(b[f"{n}/reported"] for n in s.budget.names)
    exch = sum(b[f"{n}/exchange"] for n in s.budget.names)
    assert np.allclose(
        b["residual_external"], b["momentum_change"] - b["gravity"] + rep, rtol=1e-14, atol=0
    )
    assert np.allclose(rep, reported, rtol=1e-12, atol=0)
    assert np.abs(exch).max() > 0.0


@pytest.mark.parametrize("load", ["exchange", "normal", "normal_pairs"])
def test_plate_exchange_is_the_participants_force(load):
    """Coupled δ-SPH on the clamped plate: the budget's exchange with the plate patch over a
    window is dt times the force the participant hands the structure (its step-mean
    reaction), to round-off, with fluid.sph.structure_load = "exchange" and "normal_pairs"
    (the fluid's pairs projected too); with "normal" (the default) the participant hands over
    only the exchange's part normal to the plate's faces (vertical: the plate is horizontal,
    clamped at both ends, no free end), which equals the budget's to round-off, while the
    budget books the whole exchange."""
    over = ['fluid.method="delta-sph"', "fluid.spacing=0.05", "run.threads=1",
            "fluid.momentum_budget=true", f'fluid.sph.structure_load="{load}"']  # fmt: skip
    loaded = load_scenario(PLATE, over)
    sc = loaded.scenario
    st = StructureParticipant(sc.structure, base_dir=PLATE.parent)
    fl = create_fluid_participant(
        sc.fluid, st.interface(), base_dir=PLATE.parent, member_names=["plate"]
    )
    scheme = create_scheme(fl, st, sc.coupling, log=lambda m: None)
    scheme.initialize()
    s = fl.solver
    s.budget.take(s.vel, s.kind)
    t0 = s.t
    fl.write("displacement", fl._d + 1e-6)
    fl.advance(s.dt_next)
    dt = s.t - t0
    b = s.budget.take(s.vel, s.kind)
    ext = [pt.name for pt in s.patches if pt.spec is None]
    assert ext
    told = dt * fl.read("forces").sum(axis=0)
    got = sum(b[f"{n}/exchange"] for n in ext)
    rep = sum(b[f"{n}/reported"] for n in ext)
    tol = 1e-12 * np.abs(told).max()  # round-off of the force's own size
    axes = [1] if load == "normal" else [0, 1]
    assert np.abs(got - told)[axes].max() < tol
    assert np.abs(rep - told)[axes].max() < tol
    if load == "normal":  # the tangential (x) exchange is not handed over
        assert told[0] == 0.0 and got[0] != 0.0


@pytest.mark.parametrize("integrator", ["rk4", "symplectic"])
def test_budget_restarts_bit_identically(integrator):
    """The ledger and the last split are state: a restored solver books the same budget."""
    a = _dam(integrator)
    for _ in range(3):
        a.step(a.dt_next)
    arrays = {k: v.copy() for k, v in a.state().items()}
    meta = a.meta()
    for _ in range(3):
        a.step(a.dt_next)
    b = _dam(integrator)
    b.restore(arrays, meta)
    for _ in range(3):
        b.step(b.dt_next)
    got, want = b.budget.take(b.vel, b.kind), a.budget.take(a.vel, a.kind)
    assert got.keys() == want.keys()
    for k in want:
        assert np.array_equal(got[k], want[k]), k
