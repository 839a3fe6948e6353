"""The potential-flow (shaped) fictitious mass against a fluid whose added mass is a full
operator (issue 21, task H1): structure_fem.fictitious_mass with fictitious_mass_model =
"potential_flow" on the FEM beam, at structure / added mass about 5e-5.

``OperatorFluid`` is a mock whose force answers to the wall's acceleration through a dense
added-mass matrix, the impact potential-flow operator of the whole member wetted on one face
(structure_fem.added_mass_potential, computed here on a finer panel mesh, refine 16, than the
structure's default 8, so the two are not identical): F = F_0 - n_i (M_a (n . a))_i, with a the
velocity change over the step, as mock.AddedMassFluid. Over a window that is the window's mean
acceleration, (a_0 + a_1) / 2 under Newmark's trapezoidal rule (gamma = 1/2): the added mass
the fluid presents to the window-end acceleration a_1, on which the fictitious mass acts, is
gamma M_a. So M_f = 0.5 M_a (``fictitious_mass`` = 0.5) is the exact match here: every mode's
factor (m_f - m_a) / (m_s + m_f) is the two meshes' mismatch, and unrelaxed windows converge
at the second iterate. A lumped M_f matches one mode only (the rigid heave's added mass per
unit length, scaled alike): the short modes, whose added mass is far below it, contract by a
factor near 1, and below it the long ones diverge."""

import copy
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

from mpsfem.coupler.coupling_scheme import create_scheme
from mpsfem.coupler.participant import InterfaceMesh
from mpsfem.scenario.coupling import CouplingSection
from mpsfem.structure_fem.added_mass_potential import patch_added_mass, patch_coordinates
from mpsfem.structure_fem.participant import StructureParticipant

sys.path.insert(0, str(Path(__file__).parents[1] / "structure_fem"))
structure_cases = pytest.importorskip("structure_cases")

RHO = 1000.0  # kg/m^3, the fluid
LENGTH = 0.25  # m, structure_cases.BEAM
HEAVE = RHO * np.pi * LENGTH / 8.0  # kg/m^2: rigid-heave added mass per unit length (98.2)


class OperatorFluid:
    """Points on the +normal face of a straight 2D member at its nodes; force F = F_0 - n_i
    (M_a (n . a))_i, a the wall's acceleration over the fluid's step (N/m)."""

    name = "fluid"

    def __init__(self, structure, pressure: float = 200.0, dt: float = 4e-5) -> None:
        mesh = structure.interface()
        nodes = np.asarray(mesh.points, dtype=float)
        self.n = np.asarray(mesh.normals, dtype=float)
        half = 0.5 * float(np.max(mesh.thickness))
        self.mesh = InterfaceMesh(nodes + half * self.n, self.n)
        s = patch_coordinates(nodes)
        self.Ma = patch_added_mass(s, RHO, refine=16)
        tributary = np.zeros(s.size)
        tributary[:-1] += 0.5 * np.diff(s)
        tributary[1:] += 0.5 * np.diff(s)
        self.load = -pressure * tributary[:, None] * self.n
        self.dt, self.t = dt, 0.0
        self.v_in = np.zeros_like(nodes)
        self.v_old = np.zeros_like(nodes)
        self.F = self.load.copy()
        self.started = False
        self._ckpt = None

    def interface(self):
        return self.mesh

    def write(self, name, array):
        arr = np.array(array, dtype=float)
        if name == "velocity":
            self.v_in = arr
            if not self.started:
                self.v_old = arr.copy()
        elif name != "displacement":
            raise KeyError(name)

    def read(self, name):
        if name != "forces":
            raise KeyError(name)
        return self.F.copy()

    def advance(self, dt):
        an = np.einsum("ij,ij->i", (self.v_in - self.v_old) / dt, self.n)
        self.F = self.load - (self.Ma @ an)[:, None] * self.n
        self.v_old = self.v_in.copy()
        self.t += dt
        self.started = True
        return dt

    def max_dt(self):
        return self.dt

    def checkpoint(self):
        self._ckpt = (self.t, self.v_old.copy(), self.F.copy(), self.v_in.copy())

    def restore(self):
        t, vo, F, vi = self._ckpt
        self.t, self.v_old, self.F, self.v_in = t, vo.copy(), F.copy(), vi.copy()


def run(model, mf, acceleration, rtol=1e-3, ftol=1e-3, max_it=60, end=1e-3):
    beam = copy.deepcopy(structure_cases.BEAM)
    # inextensible (the fluid's operator acts along the normal only) and light: 0.0044 kg/m^2
    # against 98 kg/m^2 of heave added mass
    beam.update(axial=False, fictitious_mass=mf, fictitious_mass_model=model)
    beam["material"] = dict(beam["material"], density=0.11)
    st = StructureParticipant(structure_cases.section([beam]), fluid_density=RHO)
    fl = OperatorFluid(st)
    cfg = CouplingSection.model_validate(
        {
            "mapping": {"kind": "shape-function"},
            "acceleration": acceleration,
            "convergence": {
                "relative_tolerance": rtol,
                "absolute_tolerance": 1e-22,
                "relative_to": "window_motion",
                "max_iterations": max_it,
                "fictitious_force_tolerance": ftol,
                "on_divergence": "continue",
            },
        }
    )
    sch = create_scheme(fl, st, cfg)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # unconverged windows are accepted and counted
        sch.run(end)
    return sch.history_arrays(), st.read("displacement")[:, 0]


CONSTANT = {"kind": "constant", "relaxation": 1.0}
AITKEN = {"kind": "aitken"}


def test_shaped_fictitious_mass_converges_at_the_second_iterate():
    """Unrelaxed, same tolerances (rtol 1e-3 of the window's motion, force error 1e-3 of the
    load), 10 windows. Measured: potential-flow M_f 0.5 x M_a 2.0 iterations per window (max 2),
    1 x M_a 9.9; lumped 0.5 / 1 x the heave added mass 14.4 / 28.8, 0.25 x diverges (stops at
    60 unconverged). The answers agree within 1e-3 where converged."""
    h_pf, d_pf = run("potential_flow", 0.5, CONSTANT)
    assert h_pf["converged"].all() and h_pf["iterations"].max() == 2
    h_pf1, d_pf1 = run("potential_flow", 1.0, CONSTANT)
    h_lu, d_lu = run("lumped", 0.5 * HEAVE, CONSTANT)
    h_lu1, d_lu1 = run("lumped", HEAVE, CONSTANT)
    for h in (h_pf1, h_lu, h_lu1):
        assert h["converged"].all()
    assert h_lu["iterations"].mean() >= 5.0 * h_pf["iterations"].mean()
    assert h_lu1["iterations"].mean() >= 2.0 * h_pf1["iterations"].mean()
    h_lq, _ = run("lumped", 0.25 * HEAVE, CONSTANT)
    assert not h_lq["converged"].any()
    scale = np.abs(d_pf).max()
    for d in (d_pf1, d_lu, d_lu1):
        assert np.abs(d - d_pf).max() <= 2e-3 * scale


def test_shaped_fictitious_mass_under_aitken():
    """Aitken (the light plate's accelerator): potential-flow 0.5 x M_a 3.0 iterations per
    window, lumped 0.25 / 0.5 / 1 x heave 6.6 / 7.9 / 10.3 (measured)."""
    h_pf, _ = run("potential_flow", 0.5, AITKEN)
    assert h_pf["converged"].all() and h_pf["iterations"].max() <= 3
    for f in (0.25, 0.5, 1.0):
        h_lu, _ = run("lumped", f * HEAVE, AITKEN)
        assert h_lu["converged"].all()
        assert h_lu["iterations"].mean() >= 2.0 * h_pf["iterations"].mean()


def test_lumped_default_is_unchanged():
    """fictitious_mass_model = "lumped" (the default) builds the same M_f as before the key:
    the nodal blocks m_f A_i n_i n_i^T, diagonal over the translations."""
    from mpsfem.structure_fem.fictitious_mass import fictitious_mass_matrix

    beam = copy.deepcopy(structure_cases.BEAM)
    beam.update(axial=False, fictitious_mass=HEAVE)
    st = StructureParticipant(structure_cases.section([beam]))
    B_default = fictitious_mass_matrix(st.system, [HEAVE])
    B_lumped = fictitious_mass_matrix(st.system, [HEAVE], None, ["lumped"], None)
    assert (B_default != B_lumped).nnz == 0
    assert (B_default - sp_diag(B_default)).nnz == 0  # one normal component per node: x only


def sp_diag(B):
    import scipy.sparse as sp

    return sp.diags(B.diagonal())


def test_force_error_column_stays_one_row_per_window(tmp_path):
    """A window in which no fictitious mass acted records no force error (WindowRecord's row
    leaves it out): the results file writes NaN there, so /coupling/fictitious_force_error
    stays aligned with /coupling/time (before: it was shorter and shifted, found on the light
    plate with fictitious_wet_pressure, whose wet set empties between wet windows)."""
    import h5py

    from mpsfem.results.results_file import ResultsFile

    path = tmp_path / "r.h5"
    rf = ResultsFile.create(path, "title = 'x'", [], {})
    rf.append_coupling(0.1, 1, 1e-5)
    rf.append_coupling(0.2, 3, 1e-5, fictitious_force_error=0.02)
    rf.append_coupling(0.3, 1, 1e-5)
    rf.append_coupling(0.4, 5, 1e-5, fictitious_force_error=0.04)
    rf.close("finished")
    with h5py.File(path, "r") as h5:
        e = h5["coupling"]["fictitious_force_error"][:]
        assert h5["coupling"]["time"].shape == e.shape == (4,)
        assert np.isnan(e[[0, 2]]).all() and e[1] == 0.02 and e[3] == 0.04
