"""Fictitious added mass (structure_fem.fictitious_mass; issue 21): the matrix, the step at a
converged fixed point, the iteration history across checkpoint / restore, the scenario key."""

import copy
from pathlib import Path

import numpy as np
import pytest
import scipy.sparse as sp
import structure_cases as sc

from mpsfem.scenario.base import ScenarioError
from mpsfem.scenario.loader import load_scenario
from mpsfem.structure_fem.fictitious_mass import fictitious_mass_matrix, shift_factor
from mpsfem.structure_fem.newmark import Newmark
from mpsfem.structure_fem.participant import StructureParticipant
from mpsfem.structure_fem.system import StructureSystem

PLATE_TOML = Path(__file__).resolve().parents[2] / "scenarios" / "hydrostatic_plate_2d.toml"


def member(base, **kw):
    m = copy.deepcopy(base)
    m.update(kw)
    return m


def test_matrix_lumps_the_mass_along_the_normal():
    """Beam (0.25 m, normal x): a unit normal translation carries m_f L, a tangential one
    nothing; BFS plate (0.3 x 0.15 m, normal z): m_f a b, in-plane nothing."""
    for base, measure, normal in ((sc.BEAM, 0.25, [1.0, 0.0]), (sc.PLATE, 0.045, [0, 0, 1.0])):
        sysm = StructureSystem(sc.section([member(base, fictitious_mass=70.0)]))
        B = fictitious_mass_matrix(sysm, [70.0])
        n = np.tile(normal, sysm.n_points)
        tang = np.tile(np.roll(normal, 1), sysm.n_points)
        assert n @ (B @ n) == pytest.approx(70.0 * measure, rel=1e-12)
        assert abs(tang @ (B @ tang)) < 1e-12
        assert fictitious_mass_matrix(sysm, [0.0]) is None


def test_shift_factor_matches_newmark_substeps():
    """c_n: n Newmark sub-steps with every end acceleration shifted by delta end c_n h^2 delta
    further (checked by stepping a free mass, K = 0)."""
    for n in (1, 2, 5):
        for beta, gamma in ((0.25, 0.5), (0.3025, 0.6)):
            ends = []
            for shift in (0.0, 1.0):
                u, v, a, h = 0.0, 0.3, 2.0, 1e-3
                for _ in range(n):
                    a1 = 2.0 + shift
                    u = u + h * v + h * h * ((0.5 - beta) * a + beta * a1)
                    v = v + h * ((1 - gamma) * a + gamma * a1)
                    a = a1
                ends.append(u)
            c = shift_factor(n, beta, gamma)
            assert ends[1] - ends[0] == pytest.approx(c * h * h, rel=1e-9)


def test_step_at_a_fixed_point_is_the_plain_newmark_step():
    """a_prev = a1 of the plain step: (M + M_f) a1 + C v1 + K u1 = F1 + M_f a1 is the plain
    equation, so the step repeats the plain one to round-off."""
    rng = np.random.default_rng(3)
    n = 12
    A = rng.standard_normal((n, n))
    K = sp.csr_matrix(A @ A.T + n * np.eye(n))
    M = sp.csr_matrix(np.diag(rng.uniform(0.5, 2.0, n)))
    C = 1e-3 * K
    Mf = sp.csr_matrix(np.diag(rng.uniform(0.0, 1e4, n)))
    F = rng.standard_normal(n)
    plain = Newmark(M, K, C)
    fict = Newmark(M, K, C, fictitious_mass=Mf)
    for nm in (plain, fict):
        nm.initialize(F, u0=rng.standard_normal(n) * 0 + 0.1, v0=np.full(n, 0.2))
    s1 = plain.step(1e-3, 2 * F)
    s2 = fict.step(1e-3, 2 * F, a_prev=s1.a)
    for x, y in ((s1.u, s2.u), (s1.v, s2.v), (s1.a, s2.a)):
        assert np.abs(x - y).max() <= 1e-9 * np.abs(x).max()
    with pytest.raises(ValueError, match="fictitious mass"):
        plain.step(1e-3, F, a_prev=s1.a)


BEAM = member(sc.BEAM, axial=False)
LOAD = np.zeros((11, 2))
LOAD[:, 0] = 5.0  # N/m along the beam's normal (x)


def first_step(mf, kinematics="linear", iterate=None, scheme="newmark"):
    beam = member(BEAM, fictitious_mass=mf, kinematics=kinematics)
    if kinematics == "corotational":
        beam.pop("axial")
    time = {"dt": 1e-4, "scheme": scheme}
    st = StructureParticipant(sc.section([beam], time=time))
    st.write("forces", 0.5 * LOAD)
    st.checkpoint()
    return st


@pytest.mark.parametrize(
    "kinematics, scheme", [("linear", "newmark"), ("corotational", "newmark"), ("linear", "hht")]
)
def test_iterations_on_fixed_forces_converge_to_the_plain_step(kinematics, scheme):
    """The same forces re-iterated (restore, write, advance): a^{k-1} is kept across restores,
    and the steps converge to the plain step (the fixed point a^k = a^{k-1}); a window started
    at the plain step's end displacement (set_iterate) gives it at once."""
    plain = first_step(0.0, kinematics, scheme=scheme)
    plain.write("forces", LOAD)
    plain.advance(1e-4)
    u_ref = plain.read("displacement")
    st = first_step(2.0 * 1100 * 0.04, kinematics, scheme=scheme)  # M_f = 2 x the beam's mass
    gaps = []
    for _ in range(40):
        st.write("forces", LOAD)
        st.advance(1e-4)
        gaps.append(np.abs(st.read("displacement") - u_ref).max())
        st.restore()
    scale = np.abs(u_ref).max()
    assert gaps[0] > 0.1 * scale  # the fictitious mass holds the first iterate back
    assert gaps[-1] < 1e-6 * scale  # and the iterations converge to the plain step
    assert all(b < a for a, b in zip(gaps[:10], gaps[1:11], strict=True))
    # given the fixed point's iterate, the first iteration is the plain step (one sub-step)
    st2 = first_step(2.0 * 1100 * 0.04, kinematics, scheme=scheme)
    st2.set_iterate(u_ref, 1e-4)
    st2.write("forces", LOAD)
    st2.advance(1e-4)
    tol = 1e-9 if kinematics == "linear" and scheme == "newmark" else 1e-6
    assert np.abs(st2.read("displacement") - u_ref).max() <= tol * scale


def test_checkpoint_starts_a_new_window():
    """After a checkpoint the previous window's accelerations no longer serve as a^{k-1}: a
    participant with another history, put into the same state and checkpointed, gives the
    same first iterate."""
    mf = 3.0 * 1100 * 0.04
    a, b = first_step(mf), first_step(mf)
    for p in (a, b):
        p.write("forces", LOAD)
        p.advance(1e-4)
    a.restore()  # a: a second iteration, another history
    a.write("forces", 3.0 * LOAD)
    a.advance(1e-4)
    a.restore(b.checkpoint())  # same state as b, then a new window on both
    a.checkpoint()
    for p in (a, b):
        p.write("forces", 2 * LOAD)
        p.advance(1e-4)
    assert np.array_equal(a.read("displacement"), b.read("displacement"))


def test_off_by_default_and_standalone():
    """fictitious_mass = 0 (default): no fictitious matrix at all (the old code path); before
    any checkpoint (standalone) a member with one steps as without."""
    st = StructureParticipant(sc.section([BEAM]))
    assert st.fictitious is None and st.integrator.Mf is None
    plain, fict = (
        StructureParticipant(sc.section([member(BEAM, fictitious_mass=m)])) for m in (0, 50)
    )
    for p in (plain, fict):
        p.write("forces", LOAD)
        p.advance(3e-4)
    assert np.allclose(plain.read("displacement"), fict.read("displacement"), rtol=1e-12, atol=0)


def test_key_validation():
    with pytest.raises(ScenarioError, match=r"fictitious_mass = -1.0: must be >= 0"):
        load_scenario(PLATE_TOML, ["structure.members.0.fictitious_mass=-1.0"])
    with pytest.raises(ScenarioError, match=r"fictitious_mass = 100.0: acts inside the iterations"):
        load_scenario(
            PLATE_TOML,
            ["structure.members.0.fictitious_mass=100.0", 'coupling.scheme="explicit"'],
        )
    with pytest.raises(ScenarioError, match=r"fictitious_mass = 100.0: needs the structure in"):
        load_scenario(
            PLATE_TOML,
            ["structure.members.0.fictitious_mass=100.0", 'coupling.transport={kind = "mpi"}'],
        )
