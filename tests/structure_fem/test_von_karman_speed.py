"""The fast von Karman paths (issue 21) against their reference paths: the memoised internal
force, the shared membrane tables, the single-precision Newton factor, and whole time steps of a
clamped plate against the einsum kernels with the double-precision factor.

Tolerances: the kernels agree with the einsum reference to round-off (1e-13 of the largest
entry, as tests/structure_fem/test_von_karman_plate.py); whole runs to the Newton tolerance: both
paths end every step with a residual below tolerance x the forces in balance, so their
displacements may differ by about that fraction (the benchmark plate: 1.7e-11 against 1e-8).
"""

import numpy as np
import pytest
import scipy.sparse as sp

from mpsfem.scenario.structure import StructureSection
from mpsfem.structure_fem.linsolve import (
    Factor,
    SinglePrecisionFactor,
    SinglePrecisionJacobian,
)
from mpsfem.structure_fem.newton import factorize_jacobian
from mpsfem.structure_fem.participant import StructureParticipant
from mpsfem.structure_fem.von_karman_plate import VonKarmanPlateModel, _shared_tables


def plate_model(nx=4, ny=3) -> VonKarmanPlateModel:
    return VonKarmanPlateModel.create(
        name="p", element="bfs", E=1e6, nu=0.3, density=1.0, thickness=0.01,
        bcs=["clamped", "free", "simply_supported", "free"], rectangle=(1.0, 0.5, nx, ny),
    )  # fmt: skip


def test_memoised_force_is_the_fresh_force_and_survives_its_callers():
    m = plate_model()
    rng = np.random.default_rng(2)
    q1, q2 = 0.02 * rng.standard_normal((2, m.n_dof))
    f1 = m.compute_internal_force(q1)
    a = m.internal_force(q1)
    assert np.array_equal(a, f1)
    a[:] = 0.0  # a caller scribbling on its result does not reach the memo
    assert np.array_equal(m.internal_force(q1.copy()), f1)
    assert np.array_equal(m.internal_force(q2), m.compute_internal_force(q2))
    q1[0] += 1e-3  # a changed q is evaluated afresh
    assert np.array_equal(m.internal_force(q1), m.compute_internal_force(q1))
    assert not np.array_equal(m.internal_force(q1), f1)


def test_shared_tables_group_only_equal_elements():
    rng = np.random.default_rng(3)
    es = rng.standard_normal((4, 5, 3, 18))
    dx = rng.random((4, 5))
    es[2] = es[0] * (1.0 + 1e-15)  # congruent with element 0 up to round-off
    dx[2] = dx[0]
    es[3] = es[0]
    dx[3] = 1.001 * dx[0]  # same gradients, other weights: a different element
    es_t, dx_t, tid = _shared_tables(es, dx)
    assert len(es_t) == 3 and tid[0] == tid[2] and len({tid[0], tid[1], tid[3]}) == 3
    for e in range(4):
        assert np.abs(es_t[tid[e]] - es[e]).max() <= 1e-14 * np.abs(es).max()
        assert np.array_equal(dx_t[tid[e]], dx[e])
    m = plate_model()
    assert m._es.shape[0] == 1 and m._tid.shape == (m._gw.shape[0],)  # uniform mesh: one table


def test_single_precision_factor_solves_and_refuses_what_float32_cannot_hold():
    m = plate_model(6, 4)
    free = np.setdiff1d(np.arange(m.n_dof), m.fixed)
    J = m.reduced_effective(np.zeros(m.n_dof), free, 1.0, 4e6, 0.0)  # dt = 1 ms
    assert isinstance(J, SinglePrecisionJacobian)
    F = factorize_jacobian(J)
    assert isinstance(F, SinglePrecisionFactor)
    b = np.cos(np.arange(J.shape[0]))
    x, x64 = F.solve(b), Factor(sp.csc_matrix(J)).solve(b)
    assert x.dtype == np.float64
    # float32 round-off (6e-8) times a moderate condition number
    assert np.linalg.norm(x - x64) <= 1e-4 * np.linalg.norm(x64)
    # 1 - 1e-9 rounds to 1 in float32: the rounded matrix is singular, the factor is refused
    # and the double-precision one made instead
    bad = SinglePrecisionJacobian(sp.csc_matrix([[1.0, 1.0 - 1e-9], [1.0 - 1e-9, 1.0]]))
    with pytest.raises(np.linalg.LinAlgError):
        SinglePrecisionFactor(bad)
    G = factorize_jacobian(bad)
    assert not isinstance(G, SinglePrecisionFactor)
    assert G.solve(np.array([1.0, 1.0])) == pytest.approx([1.0 / (2.0 - 1e-9)] * 2, rel=1e-6)
    # an indefinite Jacobian (membrane compressed by a random state) takes the pivoted LU
    q = 0.02 * np.random.default_rng(4).standard_normal(m.n_dof)
    K = m.reduced_effective(q, free, 1.0, 4e4, 0.0)
    with pytest.raises(np.linalg.LinAlgError, match="not positive definite"):
        SinglePrecisionFactor(K)
    assert not isinstance(factorize_jacobian(K), SinglePrecisionFactor)


def clamped_plate(scheme: str) -> StructureSection:
    """A clamped 0.4 x 0.2 m plate, 1 mm, under a uniform 400 Pa step load: deflection ~ 7 h in
    8 ms, membrane action strong."""
    return StructureSection.model_validate(
        {
            "members": [
                {
                    "name": "p", "type": "plate", "element": "bfs", "origin": [0, 0, 0],
                    "size": [0.4, 0.2], "divisions": [8, 4], "bc": "clamped",
                    "material": {"youngs_modulus": 5e7, "poisson_ratio": 0.3, "density": 1800},
                    "thickness": 0.001, "kinematics": "von_karman",
                }
            ],
            "time": {"dt": 2e-4, "scheme": scheme},
            "loads": [{"kind": "pressure", "member": "p", "value": 400.0}],
        }
    )  # fmt: skip


@pytest.mark.parametrize("scheme", ["newmark", "hht"])
def test_fast_steps_agree_with_the_reference_path_to_the_newton_tolerance(scheme):
    """40 steps with the numba kernels, memoised force and single-precision factor against the
    einsum kernels (per-element tables, no memo) with the double-precision factor."""
    runs = []
    for fast in (True, False):
        part = StructureParticipant(clamped_plate(scheme), prescribed_loads=True)
        m = part.system.models[0]
        if not fast:
            m.single_precision_factor = False
            m.internal_force = m.internal_force_einsum
        ws = []
        for _ in range(40):
            part.advance(2e-4)
            ws.append(part.read("displacement")[:, 2].copy())
        kind = type(part.integrator.tangent.factor)
        assert (kind is SinglePrecisionFactor) == fast
        runs.append(np.array(ws))
    fast, ref = runs
    w_max = np.abs(ref).max()
    assert w_max > 3e-3  # large deflection (h = 1 mm): the nonlinear terms matter
    tol = part.integrator.tolerance
    change = np.abs(fast - ref).max() / w_max
    print(f"max |w_fast - w_ref| / max |w| = {change:.2e} (tolerance {tol:g})")
    assert np.abs(fast - ref).max() <= 10.0 * tol * w_max
