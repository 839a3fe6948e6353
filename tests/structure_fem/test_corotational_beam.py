"""Co-rotational beam (kinematics = "corotational") against exact large-deflection solutions.

References:

* end moment: the cantilever bends into a circle of radius R = EI / M (the moment is constant);
  the tip is at (R sin(M L / EI), R (1 - cos(M L / EI))) from the clamp;
* tip load: the elastica of a cantilever under a dead vertical end load, Mattiasson, K. (1981),
  "Numerical results from large deflection beam and frame problems analysed by means of elliptic
  integrals", Int. J. Numer. Meth. Engng 17, 145-153, Table 1 (horizontal and vertical tip
  displacement over L for P L^2 / EI = 1 ... 10); cross-checked here against the elliptic-integral
  solution computed with scipy (Frisch-Fay 1962, *Flexible Bars*, ch. 2).

Tolerances come from the discretisation error: the element is second order in h (the chord
of a circle of curvature k misses the arc by k^2 h^2 / 24), so at 20 elements the tip of a beam
rolled into a circle is within Theta sin(Theta / 2) / (12 N^2) L < 8e-4 L.
"""

import math

import numpy as np
import pytest
from scipy.optimize import brentq
from scipy.special import ellipe, ellipeinc, ellipk, ellipkinc

from mpsfem.scenario.structure import StructureSection
from mpsfem.structure_fem.corotational_beam import (
    CorotationalBeamModel,
    corotational_element_tangents,
)
from mpsfem.structure_fem.participant import StructureParticipant

# Mattiasson (1981) Table 1: P L^2 / EI -> (-u_tip / L, -v_tip / L) (horizontal, vertical)
MATTIASSON = {
    1: (0.05643, 0.30172),
    2: (0.16064, 0.49346),
    3: (0.25442, 0.60325),
    4: (0.32894, 0.66996),
    5: (0.38763, 0.71379),
    6: (0.43459, 0.74457),
    7: (0.47293, 0.76737),
    8: (0.50483, 0.78498),
    9: (0.53182, 0.79906),
    10: (0.55500, 0.81061),
}


def elastica_tip(alpha: float) -> tuple[float, float]:
    """(-u/L, -v/L) of the tip of a cantilever under a dead end load with P L^2 / EI = alpha.

    With theta0 the tip slope, k^2 = (1 + sin theta0) / 2 and sin phi1 = 1 / (k sqrt 2):
    sqrt(alpha) = K(k) - F(phi1, k) fixes theta0; x_tip / L = sqrt(2 sin theta0 / alpha) and
    y_tip / L = 1 - 2 (E(k) - E(phi1, k)) / sqrt(alpha) (Frisch-Fay 1962, eqs. 2.13-2.16).
    """

    def k2(t0):
        return (1.0 + math.sin(t0)) / 2.0

    def phi1(t0):
        return math.asin(1.0 / math.sqrt(2.0 * k2(t0)))

    t0 = brentq(
        lambda t: ellipk(k2(t)) - ellipkinc(phi1(t), k2(t)) - math.sqrt(alpha),
        1e-9,
        math.pi / 2 - 1e-12,
        xtol=1e-15,
    )
    u = 1.0 - math.sqrt(2.0 * math.sin(t0) / alpha)
    v = 1.0 - 2.0 * (ellipe(k2(t0)) - ellipeinc(phi1(t0), k2(t0))) / math.sqrt(alpha)
    return u, v


def cantilever_section(elements, *, loads=(), initial_state="rest", time=None, **member):
    """Cantilever of L = 1 m along x, EI = 1 N m^2/m, EA = 1e6 N/m, rho A = 1 kg/m^2."""
    m = {
        "name": "arm",
        "type": "beam",
        "start": [0.0, 0.0],
        "end": [1.0, 0.0],
        "elements": elements,
        "bc": ["clamped", "free"],
        "material": {"youngs_modulus": 1.0, "density": 1e-6},
        "thickness": 1.0,
        "area": 1e6,
        "second_moment": 1.0,
        "kinematics": "corotational",
    }
    m.update(member)
    return StructureSection.model_validate(
        {
            "members": [m],
            "time": time or {"dt": 1e-3},
            "loads": list(loads),
            "initial_state": initial_state,
        }
    )


def observed_order(errors, ratio=2.0):
    return [math.log(a / b) / math.log(ratio) for a, b in zip(errors, errors[1:], strict=False)]


# --------------------------------------------------------------------------- element kernels
def test_tangent_is_the_derivative_of_the_internal_force():
    """K_t (material + geometric) against central differences at a large-rotation state."""
    rng = np.random.default_rng(3)
    X = np.array([[0.0, 0.0], [0.3, 0.1]])
    D0 = np.diff(X, axis=0)
    L0 = np.hypot(D0[:, 0], D0[:, 1])
    ue = np.array([[0.02, -0.01, 2.9, -0.35, 0.12, 3.3]]) + 0.01 * rng.standard_normal((1, 6))
    f, K = corotational_element_tangents(D0, L0, 50.0, 2.0, ue)
    h = 1e-6
    Kfd = np.zeros((6, 6))
    for j in range(6):
        e = np.zeros((1, 6))
        e[0, j] = h
        Kfd[:, j] = (
            corotational_element_tangents(D0, L0, 50.0, 2.0, ue + e)[0]
            - corotational_element_tangents(D0, L0, 50.0, 2.0, ue - e)[0]
        )[0] / (2 * h)
    assert np.abs(f).max() > 1.0  # a strained state: the geometric terms matter
    assert np.allclose(K[0], Kfd, rtol=1e-6, atol=1e-6 * np.abs(Kfd).max())
    assert np.allclose(K[0], K[0].T, atol=1e-12 * np.abs(K[0]).max())


def test_rigid_motion_is_stress_free():
    """A rigid rotation (beyond 2 pi) and translation leave no force and no strain energy."""
    m = CorotationalBeamModel.create(
        name="b", start=(0, 0), end=(1, 0.5), elements=6, EI=3.0, EA=100.0, rhoA=1.0,
        bcs=["free", "free"],
    )  # fmt: skip
    for angle in (0.7, math.pi, 2 * math.pi + 1.0):
        Rm = np.array([[math.cos(angle), -math.sin(angle)], [math.sin(angle), math.cos(angle)]])
        x = m.nodes @ Rm.T + np.array([0.3, -2.0])
        q = np.zeros((m.n_nodes, 3))
        q[:, :2] = x - m.nodes
        q[:, 2] = angle
        q = q.ravel()
        # round-off only: EA times a strain of ~1e-14 (a rotation-variant model gives ~EA)
        assert np.abs(m.internal_force(q)).max() < 1e-12 * m.EA * 100
        assert m.strain_energy(q) < 1e-25
    # a node turned by a further 2 pi is strained (rotations are not taken mod 2 pi)
    q = np.zeros(m.n_dof)
    q[3 * 3 + 2] = 2 * math.pi
    assert m.strain_energy(q) > 1.0


# --------------------------------------------------------------------------- statics
def end_moment_tip(elements: int, theta: float) -> tuple[np.ndarray, float]:
    """Tip (x, y) and rotation of the cantilever under an end moment M = theta EI / L."""
    part = StructureParticipant(cantilever_section(elements))
    F = np.zeros(part.system.n)
    F[-1] = theta  # the tip rotation dof is the last free dof; EI = L = 1
    u = part.integrator.solve_static(F, increments=4)
    return part.system.models[0].nodes[-1] + u[-3:-1], u[-1]


@pytest.mark.parametrize("theta", [math.pi / 2, math.pi, 1.5 * math.pi, 2 * math.pi])
def test_end_moment_rolls_the_cantilever_into_a_circle(theta):
    R = 1.0 / theta  # R = EI / M
    exact = np.array([R * math.sin(theta), R * (1.0 - math.cos(theta))])
    tip, rot = end_moment_tip(20, theta)
    err = float(np.hypot(*(tip - exact)))
    print(f"M L / EI = {theta:.4f}: tip error {err:.2e} L at 20 elements")
    assert err <= 1e-3
    assert rot == pytest.approx(theta, rel=1e-9)  # nodal rotations are exact (constant moment)


def test_end_moment_tip_converges_at_second_order():
    theta = 1.5 * math.pi
    R = 1.0 / theta
    exact = np.array([R * math.sin(theta), R * (1.0 - math.cos(theta))])
    errs = [float(np.hypot(*(end_moment_tip(n, theta)[0] - exact))) for n in (5, 10, 20, 40)]
    orders = observed_order(errs)
    print("end moment 3 pi / 2, tip errors", [f"{e:.3e}" for e in errs], "orders", orders)
    assert min(orders) > 1.95


def test_mattiasson_table_agrees_with_the_elliptic_integrals():
    for alpha, (u, v) in MATTIASSON.items():
        ue, ve = elastica_tip(alpha)
        assert abs(ue - u) <= 6e-6 and abs(ve - v) <= 6e-6, alpha


def tip_load_run(elements: int, alpha: float) -> np.ndarray:
    """Tip displacement / L of the participant's static start under a tip load P = alpha EI / L^2."""
    load = {"kind": "point_force", "member": "arm", "position": [1.0, 0.0], "force": [0, -alpha]}
    sec = cantilever_section(elements, loads=[load], initial_state="static")
    part = StructureParticipant(sec, prescribed_loads=True)
    return part.read("displacement")[-1]


def test_tip_load_matches_the_elastica():
    """Dead vertical tip load, P L^2 / EI = 1 ... 10, 20 elements: within 1e-3 L of Table 1."""
    worst = 0.0
    for alpha, (u, v) in MATTIASSON.items():
        d = tip_load_run(20, alpha)
        err = max(abs(-d[0] - u), abs(-d[1] - v))
        worst = max(worst, err)
        assert err <= 1e-3, (alpha, d, (u, v))
    print(f"tip load, 20 elements: largest error {worst:.2e} L")


def test_tip_load_converges_at_second_order():
    u, v = elastica_tip(10.0)
    errs = []
    for n in (5, 10, 20, 40):
        d = tip_load_run(n, 10.0)
        errs.append(math.hypot(-d[0] - u, -d[1] - v))
    orders = observed_order(errs)
    print("tip load P L^2/EI = 10, errors", [f"{e:.3e}" for e in errs], "orders", orders)
    # EA = 1e6: the stretch P / EA = 1e-5 bounds what 40 elements can still show
    assert min(orders[:2]) > 1.8 and errs[-1] < errs[-2]


def test_participant_reads_large_rotations_and_applies_scene_forces():
    """read() gives scene translations and the total rotation; written nodal forces are scene
    vectors on the translation dofs (dead loads on the deformed member)."""
    part = StructureParticipant(cantilever_section(10, initial_state="static"))
    pts = part.interface().n_points
    f = np.zeros((pts, 2))
    f[-1] = [0.0, -5.0]
    part.write("forces", f)  # initial data: the static start is rebuilt under them
    d = part.read("displacement")
    u_ref, v_ref = elastica_tip(5.0)
    assert -d[-1, 0] == pytest.approx(u_ref, abs=3e-3)
    assert -d[-1, 1] == pytest.approx(v_ref, abs=3e-3)
    rot = part.read("rotation")
    assert rot.shape == (pts, 1) and rot[0, 0] == 0.0
    assert -1.3 < rot[-1, 0] < -1.1  # the elastica's tip slope 1.2154 rad, clockwise
    # equilibrium in the scene frame: the clamp's reaction (its internal force, f_int = F + R)
    # holds the tip force up, whatever the member's rotation
    m = part.system.models[0]
    q = part.system.expand(part.integrator.state.u, "arm")
    assert np.allclose(m.internal_force(q)[:2], [0.0, 5.0], atol=1e-6)


# --------------------------------------------------------------------------- dynamics
def free_vibration_drift(n_per_period: int, scheme: dict) -> tuple[float, float, float]:
    """Cantilever (EI = rho A = 1, EA = 3e4, 10 elements) started straight with a large
    first-mode velocity (tip swings through ~0.8 rad); over one linear period T1: max and final
    relative energy change, and the largest tip rotation."""
    t = 0.02
    sec = StructureSection.model_validate(
        {
            "members": [
                {
                    "name": "arm", "type": "beam", "start": [0, 0], "end": [1, 0],
                    "elements": 10, "bc": ["clamped", "free"], "thickness": t,
                    "material": {"youngs_modulus": 12 / t**3, "density": 1 / t},
                    "kinematics": "corotational",
                }
            ],
            "time": {"dt": 1e-3, **scheme},
        }
    )  # fmt: skip
    part = StructureParticipant(sec)
    it, sysm = part.integrator, part.system
    from mpsfem.structure_fem.modal import natural_modes

    modes = natural_modes(sysm.models[0], 1)
    phi = modes.shapes[sysm.models[0].free, 0]
    w1 = modes.omega[0]
    it.initialize(np.zeros(sysm.n), v0=phi * 0.6 * w1 / abs(phi[-2]))
    E0 = it.energy()
    dt = 2 * math.pi / w1 / n_per_period
    zero = np.zeros(sysm.n)
    drift, rot = 0.0, 0.0
    for _ in range(n_per_period):
        it.step(dt, zero)
        drift = max(drift, abs(it.energy() / E0 - 1.0))
        rot = max(rot, abs(it.state.u[-1]))
    return drift, it.energy() / E0 - 1.0, rot


def test_large_amplitude_energy_drift_falls_at_second_order_newmark():
    """Average acceleration on the co-rotational beam: no exact conservation (it is for linear
    members), but the energy error over a period falls as dt^2."""
    res = [free_vibration_drift(n, {}) for n in (40, 80, 160)]
    drifts = [r[0] for r in res]
    orders = observed_order(drifts)
    print("Newmark energy drift", [f"{d:.3e}" for d in drifts], "orders", orders)
    assert res[0][2] > 0.7  # large rotation indeed
    assert min(orders) > 1.8
    assert drifts[-1] < 1e-3


def test_hht_dissipates_and_converges_at_second_order():
    res = [free_vibration_drift(n, {"scheme": "hht", "hht_alpha": -0.1}) for n in (40, 80, 160)]
    drifts = [r[0] for r in res]
    orders = observed_order(drifts)
    print("HHT(-0.1) energy change", [f"{d:.3e}" for d in drifts], "orders", orders)
    assert all(r[1] < 0 for r in res)  # numerical dissipation: the energy goes down
    assert min(orders) > 1.7


def test_static_start_halves_load_increments_that_fail():
    """The full end moment M L / EI = 2 pi at once is beyond Newton's reach from the straight
    beam in 4 iterations; halving the increments gets there, to the exact closed circle."""
    sec = cantilever_section(20)
    sec.newton.max_iterations = 4
    part = StructureParticipant(sec)
    F = np.zeros(part.system.n)
    F[-1] = 2 * math.pi
    u = part.integrator.solve_static(F, increments=1)
    print("load increments taken:", part.integrator.static_increments)
    assert part.integrator.static_increments > 1
    assert np.abs(u[-3:-1] + [1.0, 0.0]).max() < 1e-9  # the tip back at the clamp
    assert u[-1] == pytest.approx(2 * math.pi)


def test_mixed_linear_and_corotational_members():
    """A linear and a co-rotational member in one system move as each does alone."""
    lin = {
        "name": "stiff", "type": "beam", "start": [2.0, 0.0], "end": [3.0, 0.0], "elements": 8,
        "bc": ["clamped", "free"], "material": {"youngs_modulus": 1e3, "density": 1.0},
        "thickness": 0.1,
    }  # fmt: skip
    cr = cantilever_section(8).members[0].model_dump()
    both = StructureSection.model_validate({"members": [cr, lin], "time": {"dt": 1e-3}})
    alone = [
        StructureSection.model_validate({"members": [m], "time": {"dt": 1e-3}}) for m in (cr, lin)
    ]
    parts = [StructureParticipant(s) for s in (both, *alone)]
    assert type(parts[2].integrator).__name__ == "Newmark"
    rng = np.random.default_rng(4)
    f = rng.standard_normal((18, 2))
    for _ in range(10):
        parts[0].write("forces", f)
        parts[1].write("forces", f[:9])
        parts[2].write("forces", f[9:])
        for p in parts:
            p.advance(1e-3)
    d = parts[0].read("displacement")
    assert np.allclose(d[:9], parts[1].read("displacement"), rtol=1e-9, atol=1e-14)
    # the linear member through Newton vs the linear Newmark: round-off
    assert np.allclose(d[9:], parts[2].read("displacement"), rtol=1e-9, atol=1e-14)


def test_modes_of_a_corotational_member():
    """Linearised about the reference, the co-rotational cantilever has the Euler-Bernoulli
    frequencies to O(h^2) (its mass is the linear-interpolation one) and labels its modes."""
    from mpsfem.structure_fem.modal import natural_modes
    from mpsfem.structure_fem.model import build_member

    # EA = 100 EI / L^2, rho A = 1: an axial mode among the low bending ones
    sec = cantilever_section(40, area=1e2, material={"youngs_modulus": 1.0, "density": 1e-2})
    res = natural_modes(build_member(sec.members[0]), 4)
    print("omega", res.omega, res.kind)
    beta_l = [1.875104, 4.694091, 7.854757]  # cantilever: cos(bL) cosh(bL) = -1
    bending = [f for f, k in zip(res.omega, res.kind, strict=True) if k == "bending"]
    for b, w in zip(beta_l, bending, strict=False):
        assert w == pytest.approx(b**2, rel=2e-3)  # omega = (beta L)^2 sqrt(EI / rho A L^4)
    axial = [w for w, k in zip(res.omega, res.kind, strict=True) if k == "axial"]
    assert axial and axial[0] == pytest.approx(math.pi / 2 * 10.0, rel=2e-3)  # c = sqrt(EA/rhoA)


def test_newmark_with_gamma_above_half_dissipates_at_first_order():
    """gamma = 0.6, beta = (gamma + 1/2)^2 / 4: unconditionally stable, numerically damped and
    first order: the energy lost over a period halves with dt."""
    scheme = {"newmark_beta": 0.3025, "newmark_gamma": 0.6}
    res = [free_vibration_drift(n, scheme) for n in (40, 80, 160)]
    losses = [-r[1] for r in res]
    orders = observed_order(losses)
    print("Newmark gamma 0.6 energy loss", [f"{d:.3e}" for d in losses], "orders", orders)
    assert all(x > 0 for x in losses)
    assert all(0.8 < p < 1.3 for p in orders)
