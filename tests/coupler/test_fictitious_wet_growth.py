"""The fictitious mass's wet set growing inside a coupling window (issue 21, task H5;
structure_fem.participant, fictitious_wet_update = "grow").

``LevelFluid`` is a mock of water below a horizontal beam that falls under its own weight: a
node whose iterate (the window-end displacement the fluid is given) is below its water level
gets the added-mass force -m_a (v_in - v_old) / dt along the normal, a dry node none. The levels
sit between the window-end prediction x = d + T v the coupler starts window ``CONTACT`` from
(dry) and the dry structure's answer (free fall, wet): contact begins in the window's second
iterate. Deciding the wet set once per window ("window", the default) from the load at the
window's start and the first iterate (both zero) leaves it empty: the window iterates without
the fictitious mass, between a dry and a wet iterate. Growing it ("grow") puts M_f on the
wetted nodes (and their neighbours) once the second iterate's forces arrive, and the window
converges in a few iterations."""

import copy
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

from mpsfem.coupler.coupling_scheme import create_scheme
from mpsfem.coupler.participant import InterfaceMesh
from mpsfem.scenario.coupling import CouplingSection
from mpsfem.structure_fem.fictitious_mass import tributary_measure
from mpsfem.structure_fem.participant import StructureParticipant

sys.path.insert(0, str(Path(__file__).parents[1] / "structure_fem"))
structure_cases = pytest.importorskip("structure_cases")

WINDOW = 1e-4  # s, the structure's dt: one step per window
MU = 4.0  # added mass / structure mass per unit length on a wet node
RHO_H = 1100.0 * 0.04  # kg/m^2, the beam's mass per unit length (and m of depth)
CONTACT = 3  # index of the window in which contact begins (0-based)
LEVEL = 0.15  # the level: this fraction of the way from the prediction to the dry answer
WINDOWS = 6


def beam_participant(update="window", mf=0.5 * MU * RHO_H):
    beam = copy.deepcopy(structure_cases.BEAM)
    # horizontal (normal +y), pinned at both ends, inextensible, loaded by its weight
    beam.update(
        end=[0.25, 0.0],
        axial=False,
        self_weight=True,
        bc=["simply_supported", "simply_supported"],
        fictitious_mass=mf,
    )
    if update != "window":
        beam["fictitious_wet_update"] = update
    return StructureParticipant(structure_cases.section([beam]))


def water_levels() -> np.ndarray:
    """Per node (m, y): LEVEL of the way from window CONTACT's prediction d + T v to the dry
    answer on the interior nodes 2 .. 8 (the others never touch the water: -inf)."""
    st = beam_participant(mf=0.0)
    st.write("forces", np.zeros((11, 2)))
    for _ in range(CONTACT):
        st.advance(WINDOW)
    pred = st.read("displacement")[:, 1] + WINDOW * st.read("velocity")[:, 1]
    st.advance(WINDOW)
    dry = st.read("displacement")[:, 1]
    level = np.full(11, -np.inf)
    level[2:9] = (pred + LEVEL * (dry - pred))[2:9]
    return level


class LevelFluid:
    """Points at the beam's nodes; force along y of a node below its level: -m_a (v_in - v_old)
    / dt (v_in the velocity given for the step's end, v_old the step start's), m_a MU x the
    beam's mass per unit length x the node's tributary length; none above it."""

    name = "fluid"

    def __init__(self, structure, level: np.ndarray) -> None:
        mesh = structure.interface()
        self.mesh = InterfaceMesh(np.array(mesh.points), np.array(mesh.normals))
        self.m_a = MU * RHO_H * tributary_measure(mesh.points, mesh.cells[0])
        self.level = level
        self.d = np.zeros_like(mesh.points)
        self.v_in = np.zeros_like(mesh.points)
        self.v_old = np.zeros_like(mesh.points)
        self.F = np.zeros_like(mesh.points)
        self.started = False
        self.t = 0.0
        self._ckpt = None
        self.contact_iterations: dict[int, list[bool]] = {}  # window -> wet per iteration
        self.window = 0

    def interface(self):
        return self.mesh

    def write(self, name, array):
        arr = np.array(array, dtype=float)
        if name == "displacement":
            self.d = arr
        elif name == "velocity":
            self.v_in = arr
            if not self.started:
                self.v_old = arr.copy()
        else:
            raise KeyError(name)

    def read(self, name):
        if name != "forces":
            raise KeyError(name)
        return self.F.copy()

    def advance(self, dt):
        wet = self.d[:, 1] < self.level
        self.F = np.zeros_like(self.d)
        self.F[wet, 1] = -self.m_a[wet] * (self.v_in[wet, 1] - self.v_old[wet, 1]) / dt
        self.contact_iterations.setdefault(self.window, []).append(bool(wet.any()))
        self.v_old = self.v_in.copy()
        self.t += dt
        self.started = True
        return dt

    def max_dt(self):
        return WINDOW

    def checkpoint(self):
        self.window = int(round(self.t / WINDOW))
        self._ckpt = (self.t, self.v_old.copy(), self.F.copy(), self.v_in.copy())

    def restore(self):
        t, vo, F, vi = self._ckpt
        self.t, self.v_old, self.F, self.v_in = t, vo.copy(), F.copy(), vi.copy()


def run(update, acceleration, max_it=20, windows=WINDOWS):
    st = beam_participant(update)
    fl = LevelFluid(st, water_levels())
    cfg = CouplingSection.model_validate(
        {
            "mapping": {"kind": "shape-function"},
            "acceleration": acceleration,
            "convergence": {
                "relative_tolerance": 1e-3,
                "absolute_tolerance": 1e-22,
                "relative_to": "window_motion",
                "max_iterations": max_it,
                "fictitious_force_tolerance": "off",
                "on_divergence": "continue",
            },
        }
    )
    sch = create_scheme(fl, st, cfg)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # unconverged windows are accepted and counted
        sch.run(windows * WINDOW)
    return sch, st, fl


CONSTANT = {"kind": "constant", "relaxation": 1.0}
AITKEN = {"kind": "aitken"}


def test_contact_in_the_second_iterate_stalls_the_window_set_and_converges_when_it_grows():
    """Unrelaxed, rtol 1e-3 of the window's motion, 20 iterations at most. In window CONTACT
    the first iterate is dry and the second wet (the premise). "window": its set stays empty,
    the iterates alternate dry / wet to the last (a period-2 cycle, unconverged); "grow": the
    set grows once, at the second iterate, and the window converges (measured: 5 iterations;
    the windows after it 2, as before contact)."""
    sch_w, st_w, fl_w = run("window", CONSTANT)
    sch_g, st_g, fl_g = run("grow", CONSTANT)
    h_w, h_g = sch_w.history_arrays(), sch_g.history_arrays()
    assert fl_w.contact_iterations[CONTACT][:2] == [False, True]
    assert fl_g.contact_iterations[CONTACT][:2] == [False, True]
    assert not h_w["converged"][CONTACT] and h_w["iterations"][CONTACT] == 20
    cycle = fl_w.contact_iterations[CONTACT]
    assert cycle == [bool(k % 2) for k in range(20)]
    assert h_g["converged"].all()
    assert h_g["iterations"][CONTACT] <= 6
    assert h_g["iterations"][CONTACT + 1 :].max() <= 3
    growths = [r.set_growths for r in sch_g.history]
    assert growths[CONTACT] == 1.0 and sum(growths) == 1.0
    # the window's wet set: the wetted nodes 2 .. 8 with one element around
    assert np.flatnonzero(st_g.fictitious_nodes).tolist() == list(range(1, 10))
    # recorded per window (results file /coupling/fictitious_set_growths); "window": no column
    assert sch_g.history[CONTACT].results_row()["fictitious_set_growths"] == 1.0
    assert all("fictitious_set_growths" not in r.results_row() for r in sch_w.history)


def test_growth_under_aitken_takes_fewer_iterations():
    """Aitken (the light plate's accelerator): the window where contact begins converges
    either way here, in fewer iterations when the set grows (measured 4 against 6)."""
    sch_w, _, _ = run("window", AITKEN)
    sch_g, _, _ = run("grow", AITKEN)
    h_w, h_g = sch_w.history_arrays(), sch_g.history_arrays()
    assert h_g["converged"].all()
    assert h_g["iterations"][CONTACT] < h_w["iterations"][CONTACT]


def test_grow_changes_nothing_before_the_set_grows():
    """Before contact (windows 0 .. CONTACT - 1, dry) "grow" steps bit for bit as "window"."""
    out = {}
    for update in ("window", "grow"):
        sch, st, _ = run(update, AITKEN, windows=CONTACT)
        assert sch.history_arrays()["iterations"].min() >= 2  # implicit, iterated
        out[update] = np.r_[st.read("displacement").ravel(), st.read("velocity").ravel()]
    assert np.abs(out["window"]).max() > 0
    assert np.array_equal(out["window"], out["grow"])
