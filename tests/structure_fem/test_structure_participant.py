"""The structure participant: protocol shapes, force mapping, sub-stepping, checkpoint/restore."""

import warnings
from types import SimpleNamespace

import numpy as np
import pytest
import scipy.sparse.linalg as sla
from structure_cases import BEAM, PLATE, section

from mpsfem.structure_fem.participant import StructureParticipant


def loaded_forces(p, scale=1.0):
    itf = p.interface()
    # a smooth pressure-like nodal load along the normals
    s = np.linspace(0.0, 1.0, itf.n_points)
    return scale * (1.0 + s)[:, None] * itf.normals


def test_interface_beam():
    b2 = dict(
        BEAM, name="wall2", start=[1.0, 0.0], end=[1.5, 0.0], elements=5, geometric_thickness=0.05
    )
    p = StructureParticipant(section([BEAM, b2]))
    itf = p.interface()
    assert itf.dim == 2 and itf.n_points == 11 + 6
    assert np.allclose(itf.points[:11, 0], 0.0) and np.allclose(itf.points[10], [0.0, 0.25])
    assert np.allclose(itf.normals[:11], [-1.0, 0.0]) and np.allclose(itf.normals[11:], [0.0, 1.0])
    assert np.allclose(itf.thickness, 0.04)
    assert np.allclose(itf.geometric_thickness[:11], 0.04)
    assert np.allclose(itf.geometric_thickness[11:], 0.05)
    assert itf.member_names == ("wall", "wall2") and list(np.unique(itf.member)) == [0, 1]
    assert itf.cells[1][0].tolist() == [11, 12] and itf.slices["wall2"] == slice(11, 17)
    with pytest.raises(ValueError):
        itf.points[0, 0] = 1.0  # read-only
    assert p.read("displacement").shape == (17, 2)
    assert p.read("velocity").shape == (17, 2)
    assert p.read("rotation").shape == (17, 1)
    assert p.max_dt() == 1e-4


def test_interface_plate():
    p = StructureParticipant(section([PLATE]))
    itf = p.interface()
    assert itf.dim == 3 and itf.n_points == 9 * 5
    assert np.allclose(itf.normals, [0.0, 0.0, 1.0])
    assert np.allclose(itf.thickness, 0.001) and np.allclose(itf.geometric_thickness, 0.015)
    assert itf.cells[0].shape == (32, 4)
    # cells anticlockwise about the normal
    q = itf.points[itf.cells[0][0]]
    area = np.cross(q[1] - q[0], q[2] - q[0]) @ itf.normals[0]
    assert area > 0
    assert p.read("rotation").shape == (45, 2)


def test_static_response_to_written_forces():
    """A constant nodal load with heavy damping settles at the static solution K u = T^T f."""
    data = dict(BEAM, rayleigh_a1=2000.0, rayleigh_a2=0.0)
    p = StructureParticipant(section([data]))
    f = loaded_forces(p, 10.0)
    p.write("forces", f)
    for _ in range(400):
        p.advance(1e-3)  # 10 sub-steps of 1e-4 each
    sysm = p.system
    u_static = np.linalg.solve(sysm.K.toarray(), sysm.nodal_load(f))
    assert np.allclose(p.read("displacement"), sysm.nodal(u_static), rtol=1e-6, atol=1e-12)
    # the normal component acts, the beam bends towards -x (its normal)
    assert p.read("displacement")[5, 0] < 0


def test_advance_substeps_equal_explicit_steps():
    a = StructureParticipant(section([BEAM]))
    b = StructureParticipant(section([BEAM]))
    f = loaded_forces(a)
    for p in (a, b):
        p.write("forces", 0.0 * f)  # initial data: no load at t = 0
    a.write("forces", f)
    a.advance(3e-4)  # three sub-steps, force ramping from 0 to f
    for k in (1, 2, 3):
        b.write("forces", f * k / 3)
        b.advance(1e-4)
    assert np.allclose(a.read("displacement"), b.read("displacement"), rtol=1e-12, atol=1e-18)
    assert a.time == pytest.approx(3e-4)


def test_checkpoint_restore_bit_for_bit():
    p = StructureParticipant(section([BEAM, dict(BEAM, name="w2", start=[1, 0], end=[1.2, 0.1])]))
    rng = np.random.default_rng(0)
    forces = [rng.normal(size=(p.interface().n_points, 2)) for _ in range(8)]
    for f in forces[:3]:
        p.write("forces", f)
        p.advance(1e-4)
    state = p.checkpoint()
    first = []
    for f in forces[3:]:
        p.write("forces", f)
        p.advance(2e-4)
        first.append((p.read("displacement").copy(), p.read("velocity").copy(), p.time))
    # implicit-coupling style: restore the last checkpoint and repeat the window
    p.restore()
    for k, f in enumerate(forces[3:]):
        p.write("forces", f)
        p.advance(2e-4)
        d, v, t = first[k]
        assert np.array_equal(p.read("displacement"), d)
        assert np.array_equal(p.read("velocity"), v)
        assert p.time == t
    # restoring an explicit state dict works too, also in a fresh participant
    q = StructureParticipant(section([BEAM, dict(BEAM, name="w2", start=[1, 0], end=[1.2, 0.1])]))
    q.restore(state)
    for f in forces[3:]:
        q.write("forces", f)
        q.advance(2e-4)
    assert np.array_equal(q.read("displacement"), first[-1][0])


def test_probes_and_energy():
    probe = SimpleNamespace(name="top", target="wall", position=[0.01, 0.125])  # 1 cm off: nearest
    p = StructureParticipant(section([BEAM]), probes=[probe])
    p.write("forces", loaded_forces(p))
    for _ in range(20):
        p.advance(1e-4)
    mid = p.probe_values()["top"]
    d = p.read("displacement")
    assert np.allclose(mid, d[5])  # node 5 of 10 sits at y = 0.125
    ke, se = p.energy()
    assert ke > 0 and se > 0
    assert p.energy("wall") == (ke, se)
    with pytest.raises(ValueError, match="not a structure member"):
        StructureParticipant(
            section([BEAM]), probes=[SimpleNamespace(name="x", target="nope", position=[0, 0])]
        )


def test_protocol_errors():
    p = StructureParticipant(section([BEAM]))
    with pytest.raises(KeyError, match="forces"):
        p.write("pressure", np.zeros((11, 2)))
    with pytest.raises(ValueError, match="shape"):
        p.write("forces", np.zeros((10, 2)))
    bad = np.zeros((11, 2))
    bad[3, 1] = np.nan
    with pytest.raises(FloatingPointError, match="point 3"):
        p.write("forces", bad)
    with pytest.raises(KeyError, match="readable"):
        p.read("stress")
    with pytest.raises(ValueError):
        p.advance(0.0)
    with pytest.raises(RuntimeError):
        p.restore()


def test_self_weight_and_static_start():
    """A horizontal clamped-clamped beam under its own weight, started at static equilibrium,
    stays there: mid deflection rho A g L^4 / (384 EI), constant in time."""
    data = dict(BEAM, start=[0.0, 0.0], end=[0.5, 0.0], elements=8, bc="clamped", self_weight=True)
    p = StructureParticipant(section([data], initial_state="static", gravity=[0.0, -9.81]))
    E, t, rho, L = 35e6, 0.04, 1100.0, 0.5
    ref = rho * t * 9.81 * L**4 / (384 * E * t**3 / 12)
    d0 = p.read("displacement")[4, 1]
    assert abs(-d0 / ref - 1) < 1e-9
    for _ in range(10):
        p.advance(1e-4)
    assert abs(p.read("displacement")[4, 1] / d0 - 1) < 1e-9
    # from rest instead: oscillates about the same static value, peak about 2 x static
    q = StructureParticipant(section([data], initial_state="rest"))
    lo = 0.0
    for _ in range(300):
        q.advance(1e-4)
        lo = min(lo, q.read("displacement")[4, 1])
    assert 1.9 < lo / d0 < 2.05


def test_prescribed_loads_only_when_asked():
    loads = [{"kind": "pressure", "member": "wall", "value": 100.0}]
    a = StructureParticipant(section([BEAM], loads=loads))
    b = StructureParticipant(section([BEAM], loads=loads), prescribed_loads=True)
    a.advance(1e-3)
    b.advance(1e-3)
    assert np.all(a.read("displacement") == 0.0)
    assert np.abs(b.read("displacement")).max() > 0


def test_conditionally_stable_scheme_checks_dt():
    """Linear acceleration (beta = 1/6) is only conditionally stable: a too long dt is refused."""
    sec = section([dict(BEAM, elements=50)])
    ok = sec.model_copy(
        update={"time": sec.time.model_copy(update={"newmark_beta": 1 / 6, "dt": 1e-7})}
    )
    StructureParticipant(ok)
    bad = sec.model_copy(
        update={"time": sec.time.model_copy(update={"newmark_beta": 1 / 6, "dt": 1e-4})}
    )
    with pytest.raises(ValueError, match="stability limit"):
        StructureParticipant(bad)


@pytest.mark.parametrize("initial_state", ["rest", "static"])
def test_forces_written_at_start_are_initial_data(initial_state):
    """Forces written before the first advance set the start state: a0 from M a0 = F0 - K u0
    (and u0 = K^-1 F0 for the static start). Check: under that constant load the undamped
    average-acceleration scheme keeps E = T + U - F.u exactly (a discrete invariant when every
    a_n is in equilibrium); with a0 from the prescribed loads alone it drifts from the first
    step by about dt^2 |F|^2 / (4 m) per node. The static start stays at rest."""
    data = dict(BEAM, rayleigh_a1=0.0, rayleigh_a2=0.0)
    p = StructureParticipant(section([data], initial_state=initial_state))
    f = loaded_forces(p, 50.0)
    p.write("forces", f)
    F = p.system.nodal_load(f)
    s = p.integrator.state
    assert np.allclose(p.system.M @ s.a, F - p.system.K @ s.u, rtol=0, atol=1e-9 * np.abs(F).max())
    for _ in range(50):
        p.write("forces", f)
        p.advance(p.max_dt())
    s = p.integrator.state
    kin, strain = p.energy()
    work = F @ s.u
    if initial_state == "rest":
        assert work > 0 and abs(kin + strain - work) <= 1e-9 * work
    else:
        u_static = sla.spsolve(p.system.K.tocsc(), F)
        assert np.allclose(s.u, u_static, rtol=0, atol=1e-9 * np.abs(u_static).max())


@pytest.mark.parametrize("how", ["pressure", "interface_forces", "point_force"])
def test_beam_width_is_per_metre_of_width(how):
    """A beam's model is per metre of width whatever its `width` b: a simply supported beam under
    p = 1 kPa (as a prescribed pressure, as the coupler's nodal forces in N/m per metre of width,
    or as a 10 N/m mid-span point force) deflects as the analytic per-metre beam, and its energy
    is J/m, for b = 1, for b = 2, and for b = 2 with the whole-width section given explicitly."""
    E, t, L, p, P = 1e9, 0.01, 1.0, 1000.0, 10.0
    EI = E * t**3 / 12  # per metre of width
    ref = 5 * p * L**4 / (384 * EI) if how != "point_force" else P * L**3 / (48 * EI)
    base = dict(
        name="b", type="beam", start=[0.0, 0.0], end=[L, 0.0], elements=10,
        bc="simply_supported", material={"youngs_modulus": E, "density": 1000.0},
        thickness=t, axial=False,
    )  # fmt: skip
    loads = {
        "pressure": [{"kind": "pressure", "member": "b", "value": p}],
        "point_force": [
            {"kind": "point_force", "member": "b", "position": [0.5, 0.0], "force": [0.0, P]}
        ],
        "interface_forces": [],
    }[how]
    results = []
    for extra in ({}, {"width": 2.0}, {"width": 2.0, "area": 2 * t, "second_moment": EI / E * 2}):
        sec = section([dict(base, **extra)], loads=loads, initial_state="static")
        part = StructureParticipant(sec, prescribed_loads=True)
        if how == "interface_forces":
            n = part.interface().n_points
            f = np.zeros((n, 2))
            f[:, 1] = p * L / (n - 1)  # tributary lengths: p h inside, p h / 2 at the ends
            f[[0, -1], 1] /= 2
            part.write("forces", f)
        results.append((part.read("displacement")[5, 1], part.energy()[1]))
    (w1, e1), *others = results
    # Hermite cubics are exact for the point load at a node and the uniform load's nodal
    # values; lumped nodal forces differ from the consistent load by O(h^2) = 1 %
    assert abs(w1 / ref - 1) < (1.5e-2 if how == "interface_forces" else 1e-9)
    for w, e in others:
        assert w == pytest.approx(w1, rel=1e-12) and e == pytest.approx(e1, rel=1e-12)


@pytest.mark.parametrize(
    "member",
    [
        dict(PLATE, bc="free", divisions=[2, 2]),  # 36 unknowns: factorised densely
        dict(PLATE, bc="free"),  # 180 unknowns: sparse
        dict(PLATE, bc=["free", "free", "free", "simply_supported"], divisions=[8, 8]),
        dict(PLATE, element="morley", bc="free", divisions=[8, 8]),
        dict(BEAM, bc="free", elements=20),  # 63 unknowns: dense
        dict(BEAM, bc="free", elements=60),
        dict(BEAM, bc=["simply_supported", "free"], elements=60),
    ],
)
def test_static_start_of_a_mechanism_is_refused(member):
    """A static start of a member that can move as a rigid body is refused, on the dense and on
    the sparse factorisation alike (a sparse one used to return deflections of 1e11 m)."""
    sec = section([dict(member, self_weight=True)], initial_state="static")
    with pytest.raises(ValueError, match="initial_state.*supported.*singular"):
        StructureParticipant(sec, prescribed_loads=True)
    # the supported member starts
    sec = section([dict(member, bc="clamped", self_weight=True)], initial_state="static")
    assert np.isfinite(StructureParticipant(sec).read("displacement")).all()


@pytest.mark.parametrize(
    "member, n_dof",
    [(dict(BEAM, elements=1, bc="clamped"), 6), (dict(PLATE, divisions=[1, 1]), 16)],
)
def test_member_with_every_dof_fixed_is_refused(member, n_dof):
    with pytest.raises(
        ValueError, match=f"'{member['name']}': bc = 'clamped' fixes every one of its {n_dof}"
    ):
        StructureParticipant(section([member]))


def test_damping_ratio_of_rigid_body_modes():
    """Rayleigh damping a1 / (2 omega) + a2 omega / 2; a rigid-body mode (omega = 0) is
    undamped without a1 and overdamped (inf) with it, without a division warning."""
    from mpsfem.structure_fem.model import build_member

    for a1, rigid in ((0.0, 0.0), (2.0, np.inf)):
        sec = section([dict(BEAM, bc="free", rayleigh_a1=a1, rayleigh_a2=1e-3)])
        model = build_member(sec.members[0])
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            zeta = model.damping_ratio(np.array([0.0, 10.0]))
        assert zeta[0] == rigid and zeta[1] == pytest.approx(a1 / 20 + 1e-3 * 5)
