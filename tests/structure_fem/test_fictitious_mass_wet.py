"""Fictitious mass on the wetted nodes only, and the force error it reports (issue 21, task H1;
structure_fem.fictitious_mass.wet_nodes, StructureParticipant.fictitious_force_error)."""

import copy
from pathlib import Path

import numpy as np
import pytest
import structure_cases as sc

from mpsfem.scenario.base import ScenarioError
from mpsfem.scenario.coupling import CouplingSection
from mpsfem.scenario.loader import load_scenario
from mpsfem.structure_fem.fictitious_mass import wet_nodes
from mpsfem.structure_fem.participant import StructureParticipant

# a horizontal inextensible beam (normal y), 10 elements, 11 nodes, 0.04 m x 1100 kg/m^3
BEAM = copy.deepcopy(sc.BEAM)
BEAM.update(end=[0.25, 0.0], axial=False)
MASS = 1100.0 * 0.04  # kg/m^2
PLATE_TOML = Path(__file__).resolve().parents[2] / "scenarios" / "hydrostatic_plate_2d.toml"
DT = 1e-4


def beam(mf, **kw):
    m = copy.deepcopy(BEAM)
    m.update(fictitious_mass=mf, **kw)
    return StructureParticipant(sc.section([m]))


def window(st, forces, iterates, rng):
    """One coupling window as the implicit scheme drives it: checkpoint, then per iterate
    set_iterate (a window-end interface displacement), write the forces, advance one step,
    restore between iterations."""
    st.checkpoint()
    for k, f in enumerate(forces):
        if k:
            st.restore()
        st.set_iterate(iterates(rng), DT)
        st.write("forces", f)
        st.advance(DT)


def test_wet_nodes_widen_by_one_element():
    cells = [np.c_[np.arange(10), np.arange(1, 11)]]
    f = np.zeros((11, 2))
    f[4, 1] = 1.0
    assert np.flatnonzero(wet_nodes([f], cells, 11)).tolist() == [3, 4, 5]
    assert np.flatnonzero(wet_nodes([f], cells, 11, margin=2)).tolist() == [2, 3, 4, 5, 6]
    assert not wet_nodes([np.zeros((11, 2))], cells, 11).any()
    assert np.flatnonzero(wet_nodes([f], cells, 11, margin=0)).tolist() == [4]


def test_wet_nodes_widen_each_member_by_its_own_margin():
    """Two members (nodes 0-10 and 11-21), one loaded node each: margins 0 and 2."""
    cells = [np.c_[np.arange(10), np.arange(1, 11)], np.c_[np.arange(11, 21), np.arange(12, 22)]]
    f = np.zeros((22, 2))
    f[[4, 15], 1] = 1.0
    assert np.flatnonzero(wet_nodes([f], cells, 22, margin=[0, 2])).tolist() == [
        4, 13, 14, 15, 16, 17
    ]  # fmt: skip
    assert np.array_equal(wet_nodes([f], cells, 22, margin=[1, 1]), wet_nodes([f], cells, 22))


def test_a_dry_member_moves_exactly_as_without_fictitious_mass():
    """Self-weight only, no interface load, windows iterated three times on arbitrary
    iterates: with M_f = 3 x its mass on the wetted nodes (none here) the member's motion is
    the plain one bit for bit; with M_f on every node (the old behaviour, switch "all") it is
    not: M_f pulls the dry member towards accelerations of iterates no fluid answered to."""
    rng = {k: np.random.default_rng(5) for k in ("plain", "wet", "all")}
    parts = {
        "plain": beam(0.0, self_weight=True),
        "wet": beam(3.0 * MASS, self_weight=True),
        "all": beam(3.0 * MASS, self_weight=True, fictitious_mass_nodes="all"),
    }
    zero = [np.zeros((11, 2))] * 3
    traces = {k: [] for k in parts}
    for _ in range(30):
        for k, st in parts.items():
            window(st, zero, lambda r: 1e-4 * r.standard_normal((11, 2)), rng[k])
            traces[k].append(np.r_[st.read("displacement")[:, 1], st.read("velocity")[:, 1]])
    plain, wet, old = (np.array(traces[k]) for k in ("plain", "wet", "all"))
    assert np.abs(plain).max() > 0  # it moves under its weight
    assert np.array_equal(wet, plain)
    assert not parts["wet"].fictitious_nodes.any()
    assert np.abs(old - plain).max() > 0.1 * np.abs(plain).max()


def test_wet_set_is_decided_once_per_window_and_refactorised_only_when_it_changes():
    """Window 1: load on nodes 4, 5 in the first iterate -> M_f on nodes 3 .. 6 (one element
    around), kept in its second iteration although that one loads node 9 only. Window 2: its
    start load (window 1's last, node 9) and first iterate (node 9) -> nodes 8 .. 10. Window 3,
    the same load: the same set, no new factorisation."""
    st = beam(MASS)
    f1, f2 = np.zeros((11, 2)), np.zeros((11, 2))
    f1[[4, 5], 1] = 3.0
    f2[9, 1] = 3.0
    rng = np.random.default_rng(0)
    window(st, [f1, f2], lambda r: np.zeros((11, 2)), rng)
    assert np.flatnonzero(st.fictitious_nodes).tolist() == [3, 4, 5, 6]
    # M_f acts on the y dofs of exactly those nodes
    rows = np.flatnonzero(abs(st.integrator.Mf).sum(axis=1))
    T = st.system.T.tocsr()
    nodes = {int(c) // 2 for r in rows for c in T[:, r].nonzero()[0]}
    assert nodes == {3, 4, 5, 6}
    window(st, [f2, f2], lambda r: np.zeros((11, 2)), rng)
    assert np.flatnonzero(st.fictitious_nodes).tolist() == [8, 9, 10]
    count = st.integrator.fictitious_factorizations
    assert st.fictitious_set_changes == 2
    window(st, [f2, f2], lambda r: np.zeros((11, 2)), rng)
    assert st.fictitious_set_changes == 2
    assert st.integrator.fictitious_factorizations == count


def test_grow_adds_the_nodes_a_later_iterate_wets_and_never_removes_any():
    """fictitious_wet_update = "grow": the window of the test above (first iterate loads nodes
    4, 5, the second node 9 only) ends with M_f on 3 .. 6 and 8 .. 10 (their free dofs), one
    growth counted;
    the next window starts from its own load (node 9: 8 .. 10) and a third iterate with no
    load removes nothing. With "window" (the default) the first window keeps 3 .. 6."""
    st = beam(MASS, fictitious_wet_update="grow")
    f1, f2 = np.zeros((11, 2)), np.zeros((11, 2))
    f1[[4, 5], 1] = 3.0
    f2[9, 1] = 3.0
    rng = np.random.default_rng(0)
    window(st, [f1, f2], lambda r: np.zeros((11, 2)), rng)
    assert np.flatnonzero(st.fictitious_nodes).tolist() == [3, 4, 5, 6, 8, 9, 10]
    assert st.fictitious_set_growths() == 1
    rows = np.flatnonzero(abs(st.integrator.Mf).sum(axis=1))
    T = st.system.T.tocsr()
    nodes = {int(c) // 2 for r in rows for c in T[:, r].nonzero()[0]}
    assert nodes == {3, 4, 5, 6, 8, 9}  # node 10 is supported: no free y dof
    window(st, [f2, f2, np.zeros((11, 2))], lambda r: np.zeros((11, 2)), rng)
    assert np.flatnonzero(st.fictitious_nodes).tolist() == [8, 9, 10]
    assert st.fictitious_set_growths() == 0
    plain = beam(MASS)
    window(plain, [f1, f2], lambda r: np.zeros((11, 2)), rng)
    assert np.flatnonzero(plain.fictitious_nodes).tolist() == [3, 4, 5, 6]
    assert plain.fictitious_set_growths() is None


def test_a_grown_node_takes_the_previous_iterate_acceleration():
    """The nodes added in the second iteration (9 and its neighbours) solve (M + M_f) a^2 +
    C v^2 + K u^2 = F^2 + M_f a^1 with a^1 the acceleration of the first iteration, as the
    nodes wet from the start: the member's residual is M_f (a^1 - a^2) over every dof, with
    M_f the grown one, and nonzero on the added nodes."""
    st = beam(MASS, fictitious_wet_update="grow")
    f1, f2 = np.zeros((11, 2)), np.zeros((11, 2))
    f1[[4, 5], 1] = 3.0
    f2[[4, 5, 9], 1] = 3.0
    st.checkpoint()
    st.write("forces", f1)
    st.advance(DT)
    a1 = st.integrator.state.a.copy()
    st.restore()
    st.write("forces", f2)
    st.advance(DT)
    assert np.flatnonzero(st.fictitious_nodes).tolist() == [3, 4, 5, 6, 8, 9, 10]
    s, sysm, Mf = st.integrator.state, st.system, st.integrator.Mf
    r = sysm.M @ s.a + sysm.C @ s.v + sysm.K @ s.u - sysm.nodal_load(f2) - st.external_load(DT)
    expected = Mf @ (a1 - s.a)
    assert np.abs(r - expected).max() <= 1e-9 * np.abs(expected).max()
    y9 = st.system.T.tocsr()[2 * 9 + 1].indices  # the dof of node 9's y translation
    assert abs(expected[y9]).max() > 1e-3 * np.abs(expected).max()


@pytest.mark.parametrize("nodes", ["wet", "all"])
def test_reported_force_error_is_the_residual_of_the_true_equation(nodes):
    """After a step on an arbitrary iterate, fictitious_force_error's e is rms(M a + C v + K u -
    F) over the dofs M_f acts on (the member's own equation, which the fictitious mass leaves
    unsatisfied), S the rms load there, A the rms tributary length of those nodes."""
    st = beam(2.0 * MASS, fictitious_mass_nodes=nodes)
    f = np.zeros((11, 2))
    f[2:9, 1] = np.linspace(1.0, 4.0, 7)
    st.write("forces", f)
    st.checkpoint()
    st.set_iterate(np.full((11, 2), 1e-3), DT)
    st.write("forces", f)
    st.advance(DT)
    s, sysm = st.integrator.state, st.system
    r = sysm.M @ s.a + sysm.C @ s.v + sysm.K @ s.u - sysm.nodal_load(f) - st.external_load(DT)
    rows = st._fm_rows
    e, S, A = st.fictitious_force_error()
    assert e == pytest.approx(np.sqrt(np.mean(r[rows] ** 2)), rel=1e-9)
    assert e > 1e-3 * S  # the iterate was far from the answer
    assert S == pytest.approx(np.sqrt(np.mean(sysm.nodal_load(f)[rows] ** 2)), rel=1e-12)
    # "wet": nodes 2 .. 8 loaded, 1 .. 9 with the margin; "all": 0 .. 10, whose ends have no
    # free y dof (clamped, simply supported): 9 y dofs either way
    assert rows.size == 9
    assert A > 0.0


def test_wet_margin_zero_keeps_the_fictitious_mass_on_loaded_nodes_only():
    """fictitious_wet_margin = 0: the window's set is the loaded nodes (2 .. 8), not their
    neighbours too (1 .. 9, the default margin of one element)."""
    f = np.zeros((11, 2))
    f[2:9, 1] = 1.0
    got = {}
    for margin in (1, 0):
        st = beam(2.0 * MASS, fictitious_mass_nodes="wet", fictitious_wet_margin=margin)
        st.write("forces", f)
        st.checkpoint()
        st.set_iterate(np.zeros((11, 2)), DT)
        st.write("forces", f)
        st.advance(DT)
        got[margin] = np.flatnonzero(st.fictitious_nodes).tolist()
    assert got == {1: list(range(1, 10)), 0: list(range(2, 9))}
    with pytest.raises(ValueError, match="fictitious_wet_margin"):
        beam(MASS, fictitious_wet_margin=-1)


def test_keys_are_validated():
    for bad in (0.0, 1.0, -1e-3, "of"):
        with pytest.raises(ValueError, match="fictitious_force_tolerance"):
            CouplingSection.model_validate({"convergence": {"fictitious_force_tolerance": bad}})
    with pytest.raises(ValueError, match="fictitious_force_floor"):
        CouplingSection.model_validate({"convergence": {"fictitious_force_floor": -1.0}})
    assert (
        CouplingSection.model_validate(
            {"convergence": {"fictitious_force_tolerance": "off"}}
        ).convergence.fictitious_force_tolerance
        == "off"
    )
    with pytest.raises(ValueError, match="fictitious_mass_nodes"):
        beam(MASS, fictitious_mass_nodes="dry")
    with pytest.raises(
        ScenarioError, match=r"fictitious_force_tolerance = 2.0: .*a number in \(0, 1\) or \"off\""
    ):
        load_scenario(PLATE_TOML, ["coupling.convergence.fictitious_force_tolerance=2.0"])


def test_wet_pressure_threshold_leaves_noise_loaded_nodes_dry():
    """fictitious_wet_pressure = 1 Pa: nodes 4, 5 at 30 Pa are wet (with one element around),
    node 9 at 1e-3 Pa (an MPS member just above the surface) is not; at the default 0 every
    loaded node is."""
    cells = [np.c_[np.arange(10), np.arange(1, 11)]]
    area = np.full(11, 0.025)
    area[[0, -1]] = 0.0125
    f = np.zeros((11, 2))
    f[[4, 5], 1] = 30.0 * 0.025
    f[9, 1] = 1e-3 * 0.025
    assert np.flatnonzero(wet_nodes([f], cells, 11, threshold=1.0 * area)).tolist() == [3, 4, 5, 6]
    assert np.flatnonzero(wet_nodes([f], cells, 11)).tolist() == [3, 4, 5, 6, 8, 9, 10]
    st = beam(MASS, fictitious_wet_pressure=1.0)
    rng = np.random.default_rng(0)
    window(st, [f, f], lambda r: np.zeros((11, 2)), rng)
    assert np.flatnonzero(st.fictitious_nodes).tolist() == [3, 4, 5, 6]
