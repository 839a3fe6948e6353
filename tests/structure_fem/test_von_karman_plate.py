"""Von Karman plate (kinematics = "von_karman") against the exact cylindrical bending of a
plate strip with immovable simply supported edges.

Reference: with nu = 0 and free long edges, a strip of span a under a uniform pressure q bends
into a cylinder, w = w(x), and the 2D von Karman equations reduce to (Timoshenko &
Woinowsky-Krieger 1959, *Theory of Plates and Shells*, sec. 3, eqs. 6-8)::

    D w'''' - N w'' = q,   N = E h / (2 a) int_0^a w'^2 dx   (immovable edges: u(0) = u(a) = 0)

whose solution for a given N (k^2 = N / D, w = w'' = 0 at both ends) is
w = q / N [(cosh k (x - a/2) - cosh(k a / 2)) / (k^2 cosh(k a / 2)) + x (a - x) / 2]; the
membrane force N solves the scalar equation above (brentq, 200-point Gauss-Legendre).
"""

import math

import numpy as np
import pytest
from scipy.optimize import brentq

from mpsfem.scenario.structure import StructureSection
from mpsfem.structure_fem.alpha_method import NonlinearNewmark
from mpsfem.structure_fem.participant import StructureParticipant
from mpsfem.structure_fem.von_karman_plate import VonKarmanPlateModel

A, B, H = 1.0, 0.25, 0.01
E = 12.0 / H**3  # D = E h^3 / 12 = 1 N m (nu = 0)


def strip_midspan(q: float) -> tuple[float, float]:
    """(w(a/2), N) of the von Karman strip (exact, see the module docstring)."""
    D, Eh = 1.0, E * H

    def slope(x, N):
        k = math.sqrt(N / D)
        return q / N * (math.sinh(k * (x - A / 2)) / (k * math.cosh(k * A / 2)) - x + A / 2)

    xg, wg = np.polynomial.legendre.leggauss(200)  # the integrand is smooth: Gauss-Legendre
    xs, ws = A / 2 * (xg + 1), A / 2 * wg

    def g(N):
        return N - Eh / (2 * A) * sum(w * slope(x, N) ** 2 for x, w in zip(xs, ws, strict=True))

    N = brentq(g, 1e-2, 1e4, xtol=1e-14, rtol=1e-14)
    k = math.sqrt(N / D)
    w = q / N * ((1.0 - math.cosh(k * A / 2)) / (k * k * math.cosh(k * A / 2)) + A * A / 8)
    return w, N


def strip_section(nx: int, q: float, **time) -> StructureSection:
    return StructureSection.model_validate(
        {
            "members": [
                {
                    "name": "strip", "type": "plate", "element": "bfs", "origin": [0, 0, 0],
                    "size": [A, B], "divisions": [nx, 2],
                    "bc": ["free", "simply_supported", "free", "simply_supported"],
                    "material": {"youngs_modulus": E, "poisson_ratio": 0.0, "density": 100.0},
                    "thickness": H, "kinematics": "von_karman",
                }
            ],
            "time": {"dt": 1e-3, **time},
            "loads": [{"kind": "pressure", "member": "strip", "value": q}],
            "initial_state": "static",
        }
    )  # fmt: skip


def midspan(part) -> float:
    nodes = part.system.models[0].nodes
    k = int(np.argmin(np.hypot(nodes[:, 0] - A / 2, nodes[:, 1] - B / 2)))
    return float(part.read("displacement")[k, 2])


def test_tangent_is_the_derivative_of_the_internal_force():
    m = VonKarmanPlateModel.create(
        name="p", element="bfs", E=1e6, nu=0.3, density=1.0, thickness=0.01,
        bcs=["clamped"] * 4, rectangle=(1.0, 0.5, 4, 2),
    )  # fmt: skip
    rng = np.random.default_rng(0)
    q = 0.02 * rng.standard_normal(m.n_dof)
    f, K = m.tangent_stiffness(q)
    h = 1e-7
    for j in rng.choice(m.n_dof, 10, replace=False):
        e = np.zeros(m.n_dof)
        e[j] = h
        fd = (m.internal_force(q + e) - m.internal_force(q - e)) / (2 * h)
        col = K[:, j].toarray().ravel()
        assert np.abs(fd - col).max() <= 1e-5 * np.abs(col).max()
        dE = (m.strain_energy(q + e) - m.strain_energy(q - e)) / (2 * h)
        assert dE == pytest.approx(f[j], rel=1e-6, abs=1e-9 * np.abs(f).max())
    assert abs(K - K.T).max() <= 1e-12 * abs(K).max()


@pytest.mark.parametrize("q", [2.0, 10.0])
def test_strip_in_cylindrical_bending_matches_the_exact_solution(q):
    w_exact, N = strip_midspan(q)
    w_linear = 5 * q * A**4 / 384  # D = 1
    errs = []
    for nx in (4, 8, 16):
        part = StructureParticipant(strip_section(nx, q), prescribed_loads=True)
        errs.append(abs(midspan(part) - w_exact) / w_exact)
    print(
        f"q = {q}: w_mid exact {w_exact:.6f} m = {w_exact / H:.2f} h (linear theory "
        f"{w_linear / H:.2f} h), N = {N:.2f} N/m; relative errors {errs}"
    )
    orders = [math.log2(e0 / e1) for e0, e1 in zip(errs, errs[1:], strict=False)]
    print(f"observed orders {orders}")
    assert w_exact < 0.8 * w_linear  # membrane action matters
    assert errs[-1] < 1e-5
    assert min(orders) > 2.5


def test_small_load_is_the_linear_plate():
    """A von Karman plate under a tiny load deflects as the linear (Kirchhoff) plate."""
    q = 1e-6
    lin = strip_section(8, q).model_dump()
    lin["members"][0]["kinematics"] = "linear"
    a = StructureParticipant(StructureSection.model_validate(lin), prescribed_loads=True)
    b = StructureParticipant(strip_section(8, q), prescribed_loads=True)
    wa, wb = a.read("displacement")[:, 2], b.read("displacement")[:, 2]
    assert np.abs(wa - wb).max() <= 1e-6 * np.abs(wa).max()


def test_von_karman_plate_steps_under_hht():
    """Dynamics: the strip released from rest under the load oscillates about the static
    solution (HHT, Newton per step) and stays bounded; energies are finite."""
    part = StructureParticipant(
        strip_section(8, 10.0, scheme="hht", hht_alpha=-0.1), prescribed_loads=True
    )
    assert isinstance(part.integrator, NonlinearNewmark)
    w_static = midspan(part)
    part.integrator.initialize(part.external_load(0.0))  # from rest: a step load
    ws = []
    for _ in range(60):
        part.advance(1e-3)
        ws.append(midspan(part))
    assert 0 < max(ws) < 2.5 * w_static
    kin, strain = part.energy()
    assert math.isfinite(kin) and strain > 0


def test_numba_kernels_match_the_einsum_reference():
    """The numba force and fixed-pattern tangent agree with the einsum kernels to round-off, on
    all dofs, on the free dofs, and in the effective matrix with Rayleigh damping."""
    m = VonKarmanPlateModel.create(
        name="p", element="bfs", E=1e6, nu=0.3, density=1.0, thickness=0.01,
        bcs=["clamped", "free", "simply_supported", "free"], rectangle=(1.0, 0.5, 4, 3),
    )  # fmt: skip
    m.rayleigh_a1, m.rayleigh_a2 = 0.3, 2e-3
    q = 0.02 * np.random.default_rng(1).standard_normal(m.n_dof)
    f_ref, K_ref = m.tangent_stiffness_einsum(q)
    f, K = m.tangent_stiffness(q)
    tol = 1e-13
    assert np.abs(m.internal_force(q) - f_ref).max() <= tol * np.abs(f_ref).max()
    assert np.abs(f - f_ref).max() <= tol * np.abs(f_ref).max()
    assert abs(K - K_ref).max() <= tol * abs(K_ref).max()
    free = np.setdiff1d(np.arange(m.n_dof), m.fixed)
    fr, Kr = m.reduced_tangent(q, free)
    assert abs(Kr - K_ref[free][:, free]).max() <= tol * abs(K_ref).max()
    assert np.array_equal(fr, f[free])
    ck, cm, cc = 1.2, 3e4, 50.0
    J_ref = ck * K_ref + (cm + cc * m.rayleigh_a1) * m.M + (cc * m.rayleigh_a2) * m.K
    J = m.reduced_effective(q, free, ck, cm, cc)
    assert abs(J - J_ref[free][:, free]).max() <= tol * abs(J_ref).max()
