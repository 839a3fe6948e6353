"""Quasi-Newton accelerators: IQN-IMVJ and its restart modes, residual scaling per field, the
complement relaxation; on linear fixed points x = A x + b and on the mock added-mass problem."""

from __future__ import annotations

import numpy as np
import pytest
from test_acceleration import iterate, make, problem

from mpsfem.coupler import mock
from mpsfem.coupler.acceleration.base import Acceleration
from mpsfem.coupler.acceleration.preconditioner import create_preconditioner
from mpsfem.coupler.coupling_scheme import create_scheme
from mpsfem.coupler.errors import CouplingDivergedError
from mpsfem.scenario.coupling import CouplingSection

D = ["displacement"]


def imvj(**kw):
    base = {"data": D, "complement_relaxation": 1.0, "filter_limit": 1e-8}
    base.update(kw)
    return make("iqn-imvj", **base)


def run_mock(mu, acc, windows=100, T=1e-3, rtol=1e-3, wrap=None):
    fluid, st = mock.pair(mu)
    cfg = CouplingSection.model_validate(
        {
            "window": T,
            "mapping": {"kind": "shape-function"},
            "acceleration": acc,
            "convergence": {"relative_tolerance": rtol, "max_iterations": 50},
        }
    )
    kw = {} if wrap is None else {"acceleration": wrap(cfg)}
    sch = create_scheme(fluid, st, cfg, **kw)
    trace = []
    sch.run(windows * T, on_window=lambda r: trace.append(st.u.copy()))
    return sch, np.array(trace)


# ---------------------------------------------------------------------- IMVJ on linear maps
@pytest.mark.parametrize("omega_c", [1.0, "auto"])
def test_imvj_converges_in_n_plus_one_iterations(omega_c):
    """Quasi-Newton property: the first window (no Jacobian yet) is a relaxation step and then
    n secant steps; the (n + 1)-th update lands on the fixed point of an n-dimensional affine
    map, so at most n + 2 evaluations (given room for n columns: max_columns). The complement
    relaxation does not change that."""
    for n in (1, 4, 12, 30):
        A, b, xs = problem(n=n)
        acc = imvj(complement_relaxation=omega_c, max_columns=n)
        k, x, hist, _ = iterate(acc, A, b, np.zeros(n))
        assert k <= n + 2, (n, k)
        np.testing.assert_allclose(x, xs, rtol=1e-8, atol=1e-10)


def test_imvj_jacobian_carried_to_the_next_window():
    """After a full window the carried J_prev is the exact inverse Jacobian: the next window
    (same A, new b) converges on its first quasi-Newton step, with no columns kept (reuse 0).
    IQN-ILS without reuse starts from scratch."""
    n = 8
    A, b, _ = problem(n=n)
    counts = {}
    for name, acc in (("imvj", imvj(reuse_windows=0)), ("ils", make("iqn-ils", reuse_windows=0,
                      filter_limit=1e-8))):  # fmt: skip
        _, x, _, _ = iterate(acc, A, b, np.zeros(n))
        acc.iterations_converged(x, A @ x + b)  # the window's accepted iterate
        acc.end_window()
        b2 = b + 0.3
        counts[name], x2, _, _ = iterate(acc, A, b2, np.zeros(n))
        np.testing.assert_allclose(x2, np.linalg.solve(np.eye(n) - A, b2), rtol=1e-7)
    assert counts["imvj"] == 2 and counts["ils"] > n, counts


def test_imvj_lowers_iterations_against_iqn_ils_without_reuse_on_the_mock():
    """The mock at mu = 10 and 1e3 (rtol 1e-3, 100 windows): IMVJ (Jacobian carried, no columns
    reused) needs clearly fewer iterations per window than IQN-ILS without reuse, and lands on
    the monolithic solution as closely."""
    for mu in (10.0, 1e3):
        means = {}
        for name, acc in (
            ("imvj", {"kind": "iqn-imvj", "data": D, "complement_relaxation": 1.0}),
            ("ils", {"kind": "iqn-ils", "reuse_windows": 0}),
        ):
            sch, u = run_mock(mu, acc)
            means[name] = sch.history.column("iterations").mean()
            ref = mock.monolithic_reference(mu, len(u))
            assert np.abs(u - ref).max() <= 1e-2 * np.abs(ref).max()
        assert means["imvj"] < 0.6 * means["ils"], (mu, means)


# ---------------------------------------------------------------------- restart modes
def windows_of(acc, A, bs, n):
    """Iterate one window per right-hand side; returns each window's (evaluations, x)."""
    out = []
    for b in bs:
        k, x, _, _ = iterate(acc, A, b, np.zeros(n))
        acc.iterations_converged(x, A @ x + b)
        acc.end_window()
        out.append((k, x))
    return out


def test_rs_svd_without_truncation_is_the_dense_jacobian():
    """RS-SVD keeps J_prev as low-rank terms and compresses them every chunk_size windows; with
    a negligible truncation the compressed J_prev equals the dense one of no-restart and both
    give the same iterates."""
    n = 10
    rng = np.random.default_rng(5)
    A, b, _ = problem(n=n)
    bs = [b + 0.2 * rng.standard_normal(n) for _ in range(7)]
    dense = imvj(restart="no-restart", reuse_windows=0)
    svd = imvj(restart="RS-SVD", chunk_size=2, truncation=1e-15, reuse_windows=0)
    wd = windows_of(dense, A, bs, n)
    ws = windows_of(svd, A, bs, n)
    assert svd.restarts == 3 and len(svd.chunk) == 2  # compressed + one fresh window
    for (kd, xd), (ks, xs) in zip(wd, ws, strict=True):
        assert kd == ks
        np.testing.assert_allclose(xs, xd, rtol=1e-8, atol=1e-12)
    J = dense.jacobian()
    np.testing.assert_allclose(svd.jacobian(), J, atol=1e-9 * np.abs(J).max())


def test_rs_svd_truncation_drops_small_modes():
    n = 10
    A, b, _ = problem(n=n, lam_min=1e-3, lam_max=3.0)
    acc = imvj(restart="RS-SVD", chunk_size=1, truncation=0.3, reuse_windows=0)
    windows_of(acc, A, [b, b + 0.1], n)
    assert acc.restarts == 2 and 0 < acc.svd_rank < n and acc.truncated > 0
    s = np.linalg.svd(acc.jacobian(), compute_uv=False)
    assert np.count_nonzero(s > 1e-12 * s[0]) == acc.svd_rank


def test_rs_0_forgets_at_a_restart():
    """RS-0: after chunk_size windows J_prev is dropped, so the next window starts with a
    relaxation step (x + omega r), as the very first one did; before the restart it starts
    with a quasi-Newton step."""
    n = 6
    A, b, _ = problem(n=n, lam_max=3.0)
    acc = imvj(restart="RS-0", chunk_size=2, reuse_windows=0, initial_relaxation=0.1)
    windows_of(acc, A, [b], n)
    assert acc.has_jacobian() and acc.restarts == 0
    windows_of(acc, A, [b + 0.1], n)
    assert not acc.has_jacobian() and acc.restarts == 1
    acc.start_window()
    x = np.ones(n)
    xn, _ = acc.compute(x, A @ x + b)
    np.testing.assert_allclose(xn, x + 0.1 * (A @ x + b - x), rtol=1e-14)


def test_rs_ls_rebuilds_from_the_last_windows_columns():
    """RS-LS: at a restart J_prev = W Z from the columns of the last restart_reuse_windows
    windows (fewer than half the rows): it satisfies their secant equations J V = W."""
    n = 40
    A, b, _ = problem(n=n, lam_max=3.0)
    acc = imvj(restart="RS-LS", chunk_size=3, restart_reuse_windows=2, reuse_windows=0)
    rng = np.random.default_rng(2)
    for _ in range(3):  # three short windows (4 evaluations each): three columns per window
        acc.start_window()
        x = rng.standard_normal(n)
        bw = b + rng.standard_normal(n)
        for _ in range(4):
            x, _ = acc.compute(x, A @ x + bw)
        acc.iterations_converged(x, A @ x + bw)
        acc.end_window()
    assert acc.restarts == 1 and len(acc.chunk) == 1
    assert set(acc.rs_tags) == {1, 2}  # the last two windows' columns
    V = np.stack(acc.rs_V, axis=1)
    W = np.stack(acc.rs_W["displacement"], axis=1)
    np.testing.assert_allclose(acc.jacobian() @ V, W, atol=1e-8 * np.abs(W).max())


@pytest.mark.parametrize("restart", ["no-restart", "RS-SVD", "RS-LS", "RS-0"])
def test_imvj_state_dict_round_trip(restart):
    n = 6
    A, b, _ = problem(n=n)
    acc = make("iqn-imvj", restart=restart, chunk_size=1)
    S = np.random.default_rng(3).standard_normal((3, n))
    for bw in (b, b + 0.1):
        iterate(acc, A, bw, np.zeros(n), secondary=S)
        x = np.zeros(n)
        acc.iterations_converged(x, A @ x + bw, {"velocity": (S @ x, S @ (A @ x + bw))})
        acc.end_window()
    clone = make("iqn-imvj", restart=restart, chunk_size=1)
    clone.load_state_dict(acc.state_dict())
    x = np.ones(n)
    xt = A @ x + b
    sec = {"velocity": (S @ x, S @ xt)}
    out = []
    for a in (acc, clone):
        a.start_window()
        out.append(a.compute(x, xt, sec))
    assert out[0][0].tobytes() == out[1][0].tobytes()
    assert out[0][1]["velocity"].tobytes() == out[1][1]["velocity"].tobytes()


# ---------------------------------------------------------------------- residual scaling
def two_field_problem(n=8, m=8, seed=4):
    """z = (x, s) with z_tilde = A z + b: the velocity-like field s is a variable of its own."""
    rng = np.random.default_rng(seed)
    Q, _ = np.linalg.qr(rng.standard_normal((n + m, n + m)))
    A = Q @ np.diag(-np.geomspace(0.5, 30.0, n + m)) @ Q.T
    return A, rng.standard_normal(n + m), n


def iterate_two_fields(acc, A, b, n, scale, max_it=200, tol=1e-8):
    """Evaluations to converge with the second field handed to the accelerator times
    ``scale`` (its unit changed); convergence is judged on the unscaled z."""
    z = np.zeros(b.size)
    acc.start_window()
    for k in range(1, max_it + 1):
        zt = A @ z + b
        if np.linalg.norm(zt - z) <= tol * np.linalg.norm(zt):
            return k
        x, sec = acc.compute(z[:n], zt[:n], {"velocity": (scale * z[n:], scale * zt[n:])})
        z = np.r_[x, sec["velocity"] / scale]
    return max_it


@pytest.mark.parametrize("kind", ["iqn-ils", "iqn-imvj"])
def test_scaling_one_field_by_1e6_does_not_change_the_iterations(kind):
    """With both fields in the least squares, writing one in units 1e6 times smaller (or
    larger) changes nothing with the value or residual-sum scaling: the weights absorb the factor
    (19 evaluations for a 16-dimensional map at every scale). Without scaling the least squares
    favours the big field, the QR2 filter drops columns that differ only in the small one, and
    the count moves (19 -> 22-23)."""
    A, b, n = two_field_problem()
    counts = {}
    for pre in ("value", "residual_sum", "none"):
        for scale in (1.0, 1e6, 1e-6):
            acc = make(kind, data=["displacement", "velocity"], preconditioner=pre,
                       complement_relaxation=1.0, reuse_windows=0)  # fmt: skip
            counts[pre, scale] = iterate_two_fields(acc, A, b, n, scale)
    for pre in ("value", "residual_sum"):
        assert counts[pre, 1e6] == counts[pre, 1.0] == counts[pre, 1e-6], counts
        assert counts[pre, 1.0] <= A.shape[0] + 4, counts  # QR2 drops a column or two
    assert counts["none", 1e6] > counts["none", 1.0] < counts["none", 1e-6], counts


class Scaled(Acceleration):
    """Hands the velocity to the wrapped accelerator in units 1e6 times smaller."""

    kind = "scaled"
    Params = None

    def __init__(self, inner, scale=1e6):
        self.inner, self.scale, self.iteration = inner, scale, 0

    def start_window(self):
        self.inner.start_window()

    def _sec(self, sec):
        return {k: (self.scale * a, self.scale * b) for k, (a, b) in (sec or {}).items()}

    def _compute(self, x, x_tilde, secondary):
        xn, sec = self.inner.compute(x, x_tilde, self._sec(secondary))
        return xn, {k: v / self.scale for k, v in sec.items()}

    def iterations_converged(self, x, x_tilde, secondary=None):
        self.inner.iterations_converged(x, x_tilde, self._sec(secondary))

    def end_window(self):
        self.inner.end_window()


def test_scaling_invariance_on_the_mock():
    """The mock with a 4 ms window (the structure sub-cycles, so displacement and velocity
    residuals are independent) at mu = 10: IMVJ's defaults (both fields, value scaling) need
    the same iterations whether the velocity is in m/s or in units 1e6 times smaller."""
    from mpsfem.coupler.acceleration import create_acceleration

    acc = {"kind": "iqn-imvj"}
    plain, _ = run_mock(10.0, acc, windows=60, T=4e-3)
    scaled, _ = run_mock(
        10.0,
        acc,
        windows=60,
        T=4e-3,
        wrap=lambda cfg: Scaled(create_acceleration(cfg.acceleration)),
    )
    a = plain.history.column("iterations")
    b = scaled.history.column("iterations")
    assert abs(a.mean() - b.mean()) <= 0.1 and a.max() <= 10, (a.mean(), b.mean())


def test_value_and_residual_sum_weights():
    sizes = [3, 2]
    values = np.r_[3.0, 0.0, 4.0, 1e3, 0.0]  # |field 0| = 5, |field 1| = 1e3
    p = create_preconditioner("value", sizes)
    p.update(False, values, values)
    np.testing.assert_allclose(p.weights, np.r_[[1 / 5] * 3, [1e-3] * 2])
    assert p.active and not create_preconditioner("value", [5]).active
    q = create_preconditioner("residual_sum", sizes)
    r = np.r_[3.0, 0.0, 4.0, 0.0, 12.0]  # |r_0| = 5, |r_1| = 12, |r| = 13
    q.update(False, values, r)
    np.testing.assert_allclose(q.field_weights, [13 / 5, 13 / 12])
    q.update(True, values, r)  # window end: sums restart, weights kept
    np.testing.assert_allclose(q.field_weights, [13 / 5, 13 / 12])
    q.update(False, values, r * np.r_[1, 1, 1, 1.5, 1.5])  # a small change: kept (threshold)
    np.testing.assert_allclose(q.field_weights, [13 / 5, 13 / 12])
    q.update(True, values, r)
    q.update(False, values, np.r_[3e-3, 0.0, 4e-3, 0.0, 12.0])  # field 0's share / 1000: reset
    assert q.field_weights[0] > 100 * 13 / 5 and q.field_weights[1] == pytest.approx(1.0)


# ---------------------------------------------------------------------- extreme added mass
def test_extreme_added_mass_needs_the_complement_relaxation():
    """mu = 1e4 (a structure 1e4 times lighter than its added mass), rtol 1e-3: preCICE's step
    (complement relaxation 1) lets unexplored directions grow 1e4-fold per iteration and the
    first window stops as diverged, with a message; IMVJ's defaults ("auto") converge every
    window, well under 5 iterations on average, onto the monolithic solution."""
    with pytest.raises(CouplingDivergedError, match="diverge"):
        run_mock(1e4, {"kind": "iqn-ils"}, windows=5)
    for mu in (1e-4, 1.0, 1e4):
        sch, u = run_mock(mu, {"kind": "iqn-imvj"})
        it = sch.history.column("iterations")
        assert sch.history.column("converged").all() and it.mean() <= 5.0, (mu, it.mean())
        ref = mock.monolithic_reference(mu, len(u))
        assert np.abs(u - ref).max() <= 2e-2 * np.abs(ref).max(), mu


def test_auto_complement_relaxation_tracks_the_steepest_secant():
    """rho = max |dr| / |dx| over the columns: about 1 + 1.24 mu on the mock at mu = 1e3."""
    sch, _ = run_mock(1e3, {"kind": "iqn-imvj"}, windows=10)
    rho = sch.acceleration.rho
    assert 0.5 * 1e3 < rho < 2.0 * 1e3
    assert sch.acceleration.omega_c() == pytest.approx(1.0 / rho)


@pytest.mark.parametrize("kind", ["iqn-ils", "iqn-imvj"])
def test_restart_window_forgets_only_the_current_windows_columns(kind):
    """After a discrete change of the map inside a window (a re-decision of the fluid's frozen
    flags), restart_window drops that window's secant pairs and keeps what earlier windows
    taught (IQN-ILS: their reused columns; IMVJ: its Jacobian)."""
    A, b, _ = problem()
    acc = make(kind, reuse_windows=8, data=["displacement"])
    x = np.zeros(len(b))
    iterate(acc, A, b, x, tol=1e-6)  # window 0: converges
    acc.iterations_converged(x, A @ x + b)
    acc.end_window()
    acc.start_window()
    for _ in range(3):  # window 1: three iterations add columns tagged 1
        xt = A @ x + b
        x, _ = acc.compute(x, xt)
    assert any(t == acc.window for t in acc.tags)
    acc.restart_window()
    assert all(t < acc.window for t in acc.tags)
    assert acc._prev is None and acc.iteration == 0
    if kind == "iqn-ils":  # (window 1's columns may have pushed some out: at most n are kept)
        assert acc.tags
    else:
        assert acc.has_jacobian()
