"""Newmark-beta: energy conservation, dynamic amplification, Rayleigh damping (references.md s. 3)."""

import numpy as np
import pytest

from mpsfem.structure_fem.beam import BeamModel
from mpsfem.structure_fem.modal import natural_modes
from mpsfem.structure_fem.newmark import Newmark


def cantilever(ne=10, a1=0.0, a2=0.0):
    m = BeamModel.create(
        name="b", start=(0, 0), end=(1, 0), elements=ne, EI=1.0, EA=1.0, rhoA=1.0,
        bcs=["clamped", "free"], axial=False, rayleigh_a1=a1, rayleigh_a2=a2,
    )  # fmt: skip
    f = m.free
    return m, m.M[f][:, f], m.K[f][:, f], m.C[f][:, f], f


def test_energy_conserved_over_1e4_steps():
    """Average acceleration conserves 1/2 v.Mv + 1/2 u.Ku of undamped free vibration."""
    m, M, K, _, f = cantilever()
    nm = Newmark(M, K)
    u0 = np.linalg.solve(
        K.toarray(), m.point_force_load(np.array([1.0, 0.0]), np.array([0, 1.0]))[f]
    )
    nm.initialize(np.zeros(len(f)), u0=u0)
    E0 = nm.energy()
    T1 = 2 * np.pi / natural_modes(m, 1).omega[0]
    dt = T1 / 40
    zero = np.zeros(len(f))
    drift = 0.0
    for _ in range(10_000):
        nm.step(dt, zero)
        drift = max(drift, abs(nm.energy() / E0 - 1))
    print(f"max relative energy drift over 1e4 steps: {drift:.2e}")
    assert drift < 1e-8
    assert nm.factorizations == 1


def test_suddenly_applied_load_peaks_at_twice_static():
    """Load shaped like the first mode (F = M phi_1) excites that mode only: peak = 2 x static."""
    m, M, K, _, f = cantilever(ne=12)
    res = natural_modes(m, 1)
    phi = res.shapes[f, 0]
    F = M @ phi
    u_static = np.linalg.solve(K.toarray(), F)
    nm = Newmark(M, K)
    nm.initialize(F)  # at rest, load on from t = 0
    T1 = 2 * np.pi / res.omega[0]
    dt = T1 / 200
    i_tip = np.argmax(np.abs(u_static))
    peak = 0.0
    for _ in range(400):
        peak = max(peak, abs(nm.step(dt, F).u[i_tip]))
    ratio = peak / abs(u_static[i_tip])
    print(f"dynamic amplification {ratio:.5f}")
    assert abs(ratio - 2.0) < 0.02


@pytest.mark.parametrize("a1, a2", [(0.3, 0.0), (0.0, 2e-3), (0.2, 1e-3)])
def test_rayleigh_damping_ratio_from_log_decrement(a1, a2):
    m, M, K, C, f = cantilever(ne=10, a1=a1, a2=a2)
    res = natural_modes(m, 1)
    w1 = res.omega[0]
    zeta = a1 / (2 * w1) + a2 * w1 / 2
    assert np.isclose(res.damping_ratio[0], zeta)
    nm = Newmark(M, K, C)
    phi = res.shapes[f, 0]
    nm.initialize(np.zeros(len(f)), u0=phi)  # released from the mode shape, at rest
    T1 = 2 * np.pi / w1
    dt = T1 / 200
    i = np.argmax(np.abs(phi))
    x = [nm.state.u[i]]
    for _ in range(200 * 12):
        x.append(nm.step(dt, np.zeros(len(f))).u[i])
    x = np.array(x)
    # peaks with parabolic interpolation
    k = np.where((x[1:-1] > x[:-2]) & (x[1:-1] >= x[2:]) & (x[1:-1] > 0))[0] + 1
    ym, y0, yp = x[k - 1], x[k], x[k + 1]
    peaks = y0 - 0.25 * (ym - yp) ** 2 / (ym - 2 * y0 + yp)
    peaks = np.concatenate([[x[0]], peaks])
    n = len(peaks) - 1
    delta = np.log(peaks[0] / peaks[-1]) / n
    zeta_num = delta / np.sqrt(4 * np.pi**2 + delta**2)
    print(f"a1={a1}, a2={a2}: zeta {zeta:.5f}, from log decrement {zeta_num:.5f} over {n} cycles")
    assert abs(zeta_num / zeta - 1) < 0.02


def test_dt_change_refactorises_and_cache_keeps_two():
    _, M, K, C, f = cantilever(a1=0.1)
    nm = Newmark(M, K, C)
    nm.initialize(np.zeros(len(f)))
    F = np.ones(len(f))
    nm.step(1e-3, F)
    nm.step(1e-3, F)
    assert nm.factorizations == 1
    nm.step(5e-4, F)
    assert nm.factorizations == 2
    nm.step(1e-3, F)  # still cached
    assert nm.factorizations == 2
    nm.step(2e-4, F)
    nm.step(5e-4, F)  # evicted by the two most recent (1e-3, 2e-4)
    assert nm.factorizations == 4


def test_rejects_invalid_parameters():
    _, M, K, _, _ = cantilever()
    with pytest.raises(ValueError, match="newmark_gamma"):
        Newmark(M, K, gamma=0.4)
    with pytest.raises(ValueError, match="newmark_beta"):
        Newmark(M, K, beta=0.0)
