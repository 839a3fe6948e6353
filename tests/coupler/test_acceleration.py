"""Accelerators on linear fixed-point problems x = A x + b with a known solution.

A = Q diag(lambda) Q^T with negative eigenvalues, the added-mass type (fixed-point factor
-m_added / m_structure per mode): plain iteration diverges once some |lambda| > 1.
"""

from __future__ import annotations

import numpy as np
import pytest

from mpsfem.coupler.acceleration import ACCELERATIONS, create_acceleration
from mpsfem.coupler.acceleration.iqn_ils import IQNILS, IQNILSParams


def problem(n=12, lam_max=20.0, lam_min=0.5, seed=1):
    rng = np.random.default_rng(seed)
    Q, _ = np.linalg.qr(rng.standard_normal((n, n)))
    A = Q @ np.diag(-np.geomspace(lam_min, lam_max, n)) @ Q.T
    b = rng.standard_normal(n)
    return A, b, np.linalg.solve(np.eye(n) - A, b)


def make(kind, **kw):
    cls = ACCELERATIONS.get(kind)
    return cls(cls.Params(kind=kind, **kw))


def iterate(acc, A, b, x0, tol=1e-10, max_it=2000, secondary=None):
    """Fixed-point iterations with acceleration; returns (evaluations, x, history of |r|)."""
    x = x0.copy()
    s = None if secondary is None else secondary @ x
    hist = []
    acc.start_window()
    for k in range(1, max_it + 1):
        xt = A @ x + b
        r = np.linalg.norm(xt - x)
        hist.append(r)
        if r <= tol * np.linalg.norm(xt) or not np.isfinite(r) or r > 1e30:
            return k, x, hist, s
        sec = None if secondary is None else {"velocity": (s, secondary @ xt)}
        x, out = acc.compute(x, xt, sec)
        if secondary is not None:
            s = out["velocity"]
    return max_it, x, hist, s


def test_plain_iteration_diverges():
    A, b, xs = problem()
    acc = make("constant", relaxation=1.0)
    k, x, hist, _ = iterate(acc, A, b, np.zeros(b.size), max_it=50)
    assert hist[-1] > 1e6 * hist[0]


def test_iqn_ils_converges_in_n_plus_one():
    for n in (1, 4, 12, 30):
        A, b, xs = problem(n=n)
        acc = make("iqn-ils", reuse_windows=0, filter="QR2", filter_limit=1e-8)
        k, x, hist, _ = iterate(acc, A, b, np.zeros(n))
        # k evaluations = k - 1 updates: one relaxation step, then n quasi-Newton steps
        assert k <= n + 3, (n, k)
        np.testing.assert_allclose(x, xs, rtol=1e-8, atol=1e-10)


def test_iqn_ils_reuse_speeds_up_next_window():
    A, b, xs = problem(n=12)
    acc = make("iqn-ils", reuse_windows=4)
    k1, *_ = iterate(acc, A, b, np.zeros(12))
    acc.end_window()
    b2 = b + 0.1  # the next window: same Jacobian, new right-hand side
    k2, x2, _, _ = iterate(acc, A, b2, np.zeros(12))
    assert k2 <= 3 < k1
    np.testing.assert_allclose(x2, np.linalg.solve(np.eye(12) - A, b2), rtol=1e-8)


def test_iqn_ils_without_reuse_forgets():
    acc = make("iqn-ils", reuse_windows=0)
    A, b, _ = problem(n=5)
    iterate(acc, A, b, np.zeros(5))
    acc.end_window()
    acc.start_window()
    assert acc.V == []


@pytest.mark.parametrize("filt", ["QR1", "QR2"])
def test_filter_drops_dependent_columns(filt):
    acc = IQNILS(IQNILSParams(kind="iqn-ils", filter=filt, reuse_windows=0))
    acc.start_window()
    rng = np.random.default_rng(0)
    v = rng.standard_normal(6)
    x = np.zeros(6)
    # residuals along one direction only: every new column is parallel to the first
    for k in range(5):
        xt = x + (k + 1.0) * v
        x, _ = acc.compute(x, xt)
    assert len(acc.V) == 1 and acc.filtered >= 2


def test_max_columns():
    acc = make("iqn-ils", max_columns=3, reuse_windows=10, filter="none")
    A, b, _ = problem(n=10)
    iterate(acc, A, b, np.zeros(10), max_it=8)
    assert len(acc.V) <= 3


def test_aitken_converges():
    A, b, xs = problem(n=12, lam_max=20.0)
    k, x, hist, _ = iterate(make("aitken"), A, b, np.zeros(12))
    assert hist[-1] < 1e-9 * np.linalg.norm(xs) and k < 400
    np.testing.assert_allclose(x, xs, rtol=1e-8)


def test_constant_relaxation_stability_limit():
    """omega < 2 / (1 + |lambda|max) converges, above it diverges."""
    A, b, xs = problem(n=8, lam_max=5.0)
    limit = 2.0 / (1.0 + 5.0)
    k, x, hist, _ = iterate(make("constant", relaxation=0.9 * limit), A, b, np.zeros(8))
    assert hist[-1] < 1e-9 * np.linalg.norm(xs)
    k, x, hist, _ = iterate(make("constant", relaxation=1.1 * limit), A, b, np.zeros(8), max_it=600)
    assert hist[-1] > hist[0]


@pytest.mark.parametrize("kind", list(ACCELERATIONS))
def test_secondary_follows_the_same_combination(kind):
    """Secondary data that are an affine function of the primary stay that function."""
    A, b, xs = problem(n=6, lam_max=3.0)
    S = np.random.default_rng(3).standard_normal((4, 6))
    kw = {"relaxation": 0.3} if kind == "constant" else {}
    k, x, hist, s = iterate(make(kind, **kw), A, b, np.zeros(6), secondary=S)
    np.testing.assert_allclose(s, S @ x, rtol=1e-10, atol=1e-12)


def test_state_dict_round_trip():
    A, b, _ = problem(n=6)
    acc = make("iqn-ils")
    iterate(acc, A, b, np.zeros(6))
    acc.end_window()
    clone = make("iqn-ils")
    clone.load_state_dict(acc.state_dict())
    x = np.ones(6)
    acc.start_window()
    clone.start_window()
    a1, _ = acc.compute(x, A @ x + b)
    a2, _ = clone.compute(x, A @ x + b)
    assert a1.tobytes() == a2.tobytes()


def test_create_from_schema_params():
    from mpsfem.scenario.coupling import CouplingSection

    acc = create_acceleration(CouplingSection().acceleration)
    assert acc.kind == "iqn-ils" and acc.params.filter == "QR2"


@pytest.mark.parametrize("filt", ["QR2", "QR1", "none"])
def test_iqn_ils_never_keeps_more_columns_than_interface_entries(filt):
    """Reused windows with different fixed points, iterated past convergence (a tight
    tolerance), give columns beyond the interface size n = 4: the oldest are dropped so that V
    stays n x <= n (the QR of a wide V crashed), and the kept columns still solve each affine
    window: once they span the space the step is exact (residual at round-off)."""
    rng = np.random.default_rng(0)
    n = 4
    A = rng.normal(size=(n, n)) * 0.9
    acc = make("iqn-ils", filter=filt, reuse_windows=8)
    for _ in range(10):
        b = rng.normal(size=n)  # a new window: a different affine fixed point
        x_star = np.linalg.solve(np.eye(n) - A, b)
        acc.start_window()
        x = rng.normal(size=n)
        for _ in range(6):
            x, _ = acc.compute(x, A @ x + b)
            assert len(acc.V) <= n
        acc.end_window()
        assert np.linalg.norm(x - x_star) <= 1e-8 * np.linalg.norm(x_star)


def test_iqn_ils_keeps_the_converged_iterations_column():
    """preCICE's iterationsConverged: the accepted iterate's differences to the previous one go
    into V and W too. A window of an n = 6 linear problem accepted at its (n + 1)-th evaluation
    has n - 1 columns from compute() plus that last one: a full secant Jacobian, so the next
    window (same A, new b) lands on its fixed point with its first quasi-Newton step; without
    the last column it needs more."""
    n = 6
    A, b, _ = problem(n=n, lam_max=5.0)
    evals = {}
    for hook in (False, True):
        acc = make("iqn-ils", reuse_windows=4, filter="QR2", filter_limit=1e-8)
        acc.start_window()
        x = np.zeros(n)
        for _ in range(n):
            x, _ = acc.compute(x, A @ x + b)
        xt = A @ x + b  # the accepted iterate's answer
        assert len(acc.V) == n - 1
        if hook:
            r_prev = acc._prev[0].copy()
            acc.iterations_converged(x, xt)
            assert len(acc.V) == n and acc.tags[0] == acc.window
            assert np.array_equal(acc.V[0], (xt - x) - r_prev)
        acc.end_window()
        b2 = b + 0.1
        evals[hook], x2, _, _ = iterate(acc, A, b2, np.zeros(n))
        np.testing.assert_allclose(x2, np.linalg.solve(np.eye(n) - A, b2), rtol=1e-8)
    assert evals[True] == 2 < evals[False], evals


@pytest.mark.parametrize("kind", ["constant", "aitken"])
def test_iterations_converged_is_a_no_op_for_relaxation(kind):
    A, b, _ = problem(n=6, lam_max=3.0)
    kw = {"relaxation": 0.3} if kind == "constant" else {}
    acc = make(kind, **kw)
    iterate(acc, A, b, np.zeros(6), max_it=5)
    state = acc.state_dict()
    x = np.ones(6)
    acc.iterations_converged(x, A @ x + b)
    assert acc.state_dict() == state


def _aitken_factors(acc, A, b, x0, max_it=400, tol=1e-10):
    """Fixed-point iterations under ``acc`` (Aitken); returns (x, the factors applied)."""
    x, factors = x0.copy(), []
    acc.start_window()
    for _ in range(max_it):
        xt = A @ x + b
        if np.linalg.norm(xt - x) <= tol * np.linalg.norm(xt):
            break
        x, _ = acc.compute(x, xt)
        factors.append(acc.omega)
    return x, np.array(factors)


def test_aitken_bounds_that_never_bind_change_nothing():
    """relaxation_bounds wide enough never to bind: the same iterates, bit for bit, as none."""
    A, b, _ = problem(n=12, lam_max=20.0)
    x0, w0 = _aitken_factors(make("aitken"), A, b, np.zeros(12))
    x1, w1 = _aitken_factors(make("aitken", relaxation_bounds=[-1e6, 1e6]), A, b, np.zeros(12))
    assert np.array_equal(x0, x1) and np.array_equal(w0, w1)


def test_aitken_factor_is_clipped_into_its_bounds():
    """Every factor applied lies in [lo, hi]; the free factors of the same problem leave that
    interval (so the bound acts), and the clipped iteration still converges: on eigenvalues
    in [-20, -0.5] every factor below 2 / 21 contracts (constant relaxation's limit)."""
    A, b, xs = problem(n=12, lam_max=20.0)
    _, free = _aitken_factors(make("aitken"), A, b, np.zeros(12))
    lo, hi = 0.02, 0.06
    assert free.min() < lo or free.max() > hi
    x, w = _aitken_factors(make("aitken", relaxation_bounds=[lo, hi]), A, b, np.zeros(12))
    assert w.min() >= lo and w.max() <= hi
    np.testing.assert_allclose(x, xs, rtol=1e-8)


@pytest.mark.parametrize(
    "bounds", [[0.5, 0.1], [0.1], [-1.0, -0.5], [0.0, float("inf")], [float("nan"), 1.0]]
)
def test_aitken_bounds_refuse_what_is_not_an_interval(bounds):
    from pydantic import ValidationError

    with pytest.raises(ValidationError, match="relaxation_bounds"):
        make("aitken", relaxation_bounds=bounds)
