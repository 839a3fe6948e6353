"""The potential-flow fictitious mass in the structure participant (issue 21, task H1;
structure_fem.fictitious_mass with fictitious_mass_model = "potential_flow")."""

import copy
from pathlib import Path

import numpy as np
import pytest
import structure_cases as sc

from mpsfem.scenario.base import ScenarioError
from mpsfem.scenario.loader import load_scenario
from mpsfem.structure_fem.added_mass_potential import patch_added_mass
from mpsfem.structure_fem.fictitious_mass import fictitious_mass_matrix, node_runs
from mpsfem.structure_fem.participant import StructureParticipant

# a horizontal inextensible beam (normal y), 10 elements, 11 nodes
BEAM = copy.deepcopy(sc.BEAM)
BEAM.update(end=[0.25, 0.0], axial=False)
RHO = 1000.0
PLATE_TOML = Path(__file__).resolve().parents[2] / "scenarios" / "hydrostatic_plate_2d.toml"
DT = 1e-4


def beam(factor, density=RHO, **kw):
    m = copy.deepcopy(BEAM)
    m.update(fictitious_mass=factor, fictitious_mass_model="potential_flow", **kw)
    return StructureParticipant(sc.section([m]), fluid_density=density)


def test_node_runs():
    pts = np.c_[np.linspace(1.0, 0.0, 8), np.zeros(8)]  # numbered against the axis
    on = np.array([1, 1, 0, 1, 0, 1, 1, 1], dtype=bool)
    runs = node_runs(pts, on)
    assert sorted(sorted(r.tolist()) for r in runs) == [[0, 1], [5, 6, 7]]
    assert all(np.all(np.diff(pts[r, 0]) != 0) for r in runs)  # ordered along the member


def test_blocks_are_the_patch_operators_of_each_wet_run_along_the_normal():
    """Nodes 1-3 and 6-9 carrying: B holds factor x patch_added_mass of each run on the y
    (normal) translations, nothing across runs or on x."""
    st = beam(0.7)
    nodes = np.zeros(11, dtype=bool)
    nodes[[1, 2, 3, 6, 7, 8, 9]] = True
    B = fictitious_mass_matrix(st.system, [0.7], nodes, ["potential_flow"], RHO).toarray()
    x = np.linspace(0.0, 0.25, 11)
    expect = np.zeros((22, 22))
    for run in ([1, 2, 3], [6, 7, 8, 9]):
        Ma = 0.7 * patch_added_mass(x[run] - x[run[0]], RHO)
        idx = np.array(run) * 2 + 1
        expect[np.ix_(idx, idx)] = Ma
    assert np.allclose(B, expect, rtol=1e-12, atol=1e-15)
    assert np.abs(B - B.T).max() < 1e-15


def test_wet_set_gives_the_dense_block_and_the_force_error_sees_it():
    """A window loading nodes 4, 5: M_f on nodes 3 .. 6 is the 4-node patch operator (dense),
    refactorised once; the reported force error is rms(M a + C v + K u - F) over those dofs."""
    st = beam(1.0)
    f = np.zeros((11, 2))
    f[[4, 5], 1] = 3.0
    st.write("forces", f)
    st.checkpoint()
    st.set_iterate(np.full((11, 2), 1e-4), DT)
    st.write("forces", f)
    st.advance(DT)
    assert np.flatnonzero(st.fictitious_nodes).tolist() == [3, 4, 5, 6]
    T = st.system.T.tocsr()
    B = (T @ st.integrator.Mf @ T.T).toarray()  # back on the nodal translations
    x = np.linspace(0.0, 0.25, 11)
    Ma = patch_added_mass(x[3:7] - x[3], RHO)
    idx = np.arange(3, 7) * 2 + 1
    assert np.allclose(B[np.ix_(idx, idx)], Ma, rtol=1e-12)
    assert np.count_nonzero(B[np.ix_(idx, idx)]) == 16  # dense, not lumped
    assert st.fictitious_set_changes == 1
    s, sysm = st.integrator.state, st.system
    r = sysm.M @ s.a + sysm.C @ s.v + sysm.K @ s.u - sysm.nodal_load(f) - st.external_load(DT)
    e, _, _ = st.fictitious_force_error()
    assert e == pytest.approx(np.sqrt(np.mean(r[st._fm_rows] ** 2)), rel=1e-9)
    assert e > 0


def test_missing_density_and_plates_are_refused():
    m = copy.deepcopy(BEAM)
    m.update(fictitious_mass=1.0, fictitious_mass_model="potential_flow")
    with pytest.raises(ValueError, match=r"members\[0\].fictitious_mass_model = 'potential_flow'"):
        StructureParticipant(sc.section([m]))
    # standalone (prescribed loads): no window, no density needed, the steps are plain
    StructureParticipant(sc.section([m]), prescribed_loads=True)
    p = copy.deepcopy(sc.PLATE)
    p.update(fictitious_mass=1.0, fictitious_mass_model="potential_flow")
    with pytest.raises(ValueError, match="fictitious_mass_model = 'potential_flow': a plate"):
        sc.section([p])
    with pytest.raises(ScenarioError, match=r"fictitious_mass_model = 'added'"):
        load_scenario(PLATE_TOML, ['structure.members.0.fictitious_mass_model="added"'])


def test_scenario_passes_the_fluid_density():
    """A coupled scenario with the key loads; its fluid.density is what the run passes
    (simulation.py builds the participant with fluid_density=sc.fluid.density)."""
    loaded = load_scenario(
        PLATE_TOML,
        [
            "structure.members.0.fictitious_mass=1.0",
            'structure.members.0.fictitious_mass_model="potential_flow"',
        ],
    )
    assert loaded.scenario.structure.members[0].fictitious_mass_model == "potential_flow"
    st = StructureParticipant(
        loaded.scenario.structure, fluid_density=loaded.scenario.fluid.density
    )
    assert st.fictitious is not None
