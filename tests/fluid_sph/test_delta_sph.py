"""δ-SPH core: kernel, CSPM correction, pair symmetry, still water, restarts."""

from __future__ import annotations

import tracemalloc

import numba
import numpy as np
import pytest

from mpsfem.fluid_mps.geometry import ParticleSet
from mpsfem.fluid_mps.neighbours import NeighbourSearch, build_neighbours
from mpsfem.fluid_sph import delta_sph
from mpsfem.fluid_sph.candidate_pairs import CandidatePairs
from mpsfem.fluid_sph.solver import DeltaSPHSolver, SPHRunError
from mpsfem.fluid_sph.wendland import gradient_factor, kernel_value, wendland_norm
from mpsfem.scenario.fluid import FluidSection, SpongeZone


def _tank(**sph):
    return FluidSection(
        method="delta-sph",
        spacing=0.02,
        blocks=[{"lower": [0.0, 0.0], "upper": [0.3, 0.2]}],
        walls=[{"shape": "tank", "lower": [0.0, 0.0], "upper": [0.3, 0.4], "name": "tank"}],
        sph=sph,
    )


def _free_block(n=12, jitter=0.0, seed=1, **sph):
    """A square of fluid without walls or gravity (particles given directly)."""
    dx = 0.1
    spec = FluidSection(
        method="delta-sph",
        spacing=dx,
        gravity=[0.0, 0.0],
        blocks=[{"lower": [0.0, 0.0], "upper": [n * dx, n * dx]}],
        sph={"sound_speed": 10.0, **sph},
    )
    g = (np.arange(n) + 0.5) * dx
    pos = np.stack(np.meshgrid(g, g, indexing="ij"), axis=-1).reshape(-1, 2)
    rng = np.random.default_rng(seed)
    pos += jitter * dx * rng.uniform(-1, 1, pos.shape)
    ps = ParticleSet(pos, np.zeros_like(pos), np.zeros(len(pos), np.int8), np.zeros_like(pos),
                     len(pos))  # fmt: skip
    return DeltaSPHSolver(spec, particles=ps), rng


@pytest.mark.parametrize("dim", [2, 3])
def test_wendland_gradient_is_the_derivative(dim):
    h = 0.013
    norm = wendland_norm(dim, h)
    for r in np.linspace(0.05, 1.95, 9) * h:
        eps = 1e-7 * h
        fd = (kernel_value(r + eps, h, norm) - kernel_value(r - eps, h, norm)) / (2 * eps)
        assert gradient_factor(r, h, norm) * r == pytest.approx(fd, rel=1e-6)


def test_wendland_is_normalised_in_2d():
    """sum_j W(r_ij) dx^2 over a fine lattice -> 1 (the quadrature error of a smooth kernel
    sampled 13 points per h is far below 1e-6)."""
    h, dx = 1.0, 1.0 / 13.0
    g = np.arange(-40, 41) * dx
    x, y = np.meshgrid(g, g)
    w = np.vectorize(lambda r: kernel_value(r, h, wendland_norm(2, h)))(np.hypot(x, y))
    assert w.sum() * dx * dx == pytest.approx(1.0, abs=1e-6)


def test_cspm_density_gradient_is_exact_for_a_linear_field():
    """M_i makes the density gradient exact for a linear field at every particle, the block's
    edges and corners included (seed eq. 7), on a jittered lattice."""
    s, _ = _free_block(jitter=0.2)
    b = np.array([3.0, -2.0])
    s.rho[:] = 1000.0 + s.pos @ b
    s.rhs()
    corrected = np.abs(s.M - np.eye(2)).max(axis=(1, 2)) > 0  # else det(B) < DET_MIN: M = I
    assert corrected.sum() >= s.n_fluid - 4  # at most the four corners fall back
    err = np.abs(s.grad_rho[corrected] - b).max()
    assert err < 1e-9 * np.abs(b).max()


@pytest.mark.parametrize("gradient", ["corrected", "plain"])
def test_pair_forces_cancel(gradient):
    """Without walls and body forces the pair terms are antisymmetric: sum_i m a_i = 0 to
    round-off for the δ-SPHC (eq. 12) and the plain (eq. 6) gradient with viscosity."""
    s, rng = _free_block(jitter=0.2, gradient=gradient, viscosity_alpha=0.1)
    s.rho[:] = 1000.0 * (1.0 + 0.01 * rng.uniform(-1, 1, s.n))
    s.vel[:] = rng.uniform(-1, 1, s.vel.shape)
    s.rhs()
    total = s.acc.sum(axis=0)
    scale = np.abs(s.acc).sum()
    assert np.abs(total).max() < 1e-13 * scale


@pytest.mark.parametrize("integrator", ["rk4", "symplectic"])
def test_still_water_keeps_hydrostatic_pressure(integrator):
    """0.2 m deep tank at 10 particles per depth, 0.1 s: the bottom row's pressure stays within
    1 % of rho g (d - y) (validation/delta_sph_hydrostatic.py runs it longer)."""
    s = DeltaSPHSolver(_tank(integrator=integrator))
    t_end = 0.1
    while s.t < t_end - 1e-12:
        s.step(s.dt_towards(t_end))
    nf = s.n_fluid
    bottom = s.pos[:nf, 1] < 0.02
    expected = 1000.0 * 9.81 * (0.2 - s.pos[:nf, 1][bottom])
    assert s.p[:nf][bottom].mean() == pytest.approx(expected.mean(), rel=0.01)
    # the surface settles by about 1 mm (lattice start); a current beyond 5 % of sqrt(g d)
    # = 1.4 m/s would be a wall that leaks or pushes
    assert np.abs(s.vel[:nf]).max() < 0.05 * np.sqrt(9.81 * 0.2)


@pytest.mark.parametrize("integrator", ["symplectic", "rk4"])
def test_restart_is_bit_identical(integrator):
    a = _tank(integrator=integrator)
    s = DeltaSPHSolver(a)
    for _ in range(5):
        s.step(s.dt_next)
    saved = {k: v.copy() for k, v in s.state().items()}
    meta = s.meta()
    for _ in range(5):
        s.step(s.dt_next)
    r = DeltaSPHSolver(a)
    r.restore(saved, meta)
    for _ in range(5):
        r.step(r.dt_next)
    for k, v in s.state().items():
        assert np.array_equal(v, r.state()[k]), k
    assert r.t == s.t and r.dt_next == s.dt_next


def test_mach_limit_stops_the_run():
    s, _ = _free_block(sound_speed=1.0, max_mach=0.1)
    s.vel[:] = [0.5, 0.0]
    s.rhs()
    with pytest.raises(SPHRunError, match="max_mach"):
        s.step(1e-4)


def test_equation_of_state():
    rho = np.array([1000.0, 1001.0, 999.0])
    p = np.zeros(3)
    delta_sph.equation_of_state(rho, p, 3, 1000.0, 20.0)
    assert np.allclose(p, [0.0, 400.0, -400.0])


@pytest.mark.skipif(numba.config.NUMBA_NUM_THREADS < 2, reason="needs 2 numba threads")
def test_results_do_not_depend_on_the_thread_count():
    """Every loop sums its own row in a fixed order: 1 and 2 threads give the same bits."""
    states = []
    for threads in (1, 2):
        numba.set_num_threads(threads)
        try:
            s = DeltaSPHSolver(_tank())
            for _ in range(5):
                s.step(s.dt_next)
        finally:
            numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
        states.append({k: v.copy() for k, v in s.state().items()})
    for k, v in states[0].items():
        assert np.array_equal(v, states[1][k]), k


@pytest.mark.parametrize("wall_acc", [[0.0, 0.0], [0.0, -9.81], [2.0, 1.0]])
def test_dummy_pressure_is_adami_extrapolation(wall_acc):
    """p_w = (sum p_f W + (g - a_w) . sum rho_f (r_w - r_f) W) / sum W (Adami et al. 2012,
    eq. 27), checked against a direct evaluation for one wall particle and three fluid ones."""
    h, dim = 0.013, 2
    norm = wendland_norm(dim, h)
    pos = np.array([[0.0, 0.01], [0.01, 0.012], [-0.008, 0.02], [0.0, -0.005]])
    rho = np.array([1001.0, 1000.5, 999.8, 0.0])
    p = np.array([200.0, 150.0, -20.0, 0.0])
    g = np.array([0.0, -9.81])
    acc = np.array([wall_acc])
    indptr = np.array([0, 0, 0, 0, 3])
    indices = np.array([0, 1, 2], dtype=np.int32)
    delta_sph.wall_pressure(pos, rho, p, np.array([0, 0, 0, 2], np.int8), indptr, indices,
                            (2 * h) ** 2, 3, g, 0.0, np.zeros(2), acc, h, norm, 1000.0,
                            20.0)  # fmt: skip
    w = np.array([kernel_value(np.linalg.norm(pos[3] - pos[j]), h, norm) for j in range(3)])
    b = g - acc[0]
    expected = (w @ p[:3] + sum(w[j] * rho[j] * b @ (pos[3] - pos[j]) for j in range(3))) / w.sum()
    assert p[3] == pytest.approx(expected, rel=1e-12)
    assert rho[3] == pytest.approx(1000.0 + expected / 400.0, rel=1e-12)


def test_clamped_wall_pressure_floors_only_the_negative_walls():
    """fluid.sph.wall_pressure = "clamped": p_w <- max(p_w, 0) on the wall particles (rho_w =
    rho0 + p_w / c0^2 with it), fluid particles and positive walls untouched, bit for bit."""
    p = np.array([-50.0, 30.0, -120.0, 80.0, 0.0])
    rho = np.array([999.9, 1000.1, 999.7, 1000.2, 1000.0])
    p0, rho0 = p.copy(), rho.copy()
    delta_sph.clamp_wall_pressure(p, rho, 2, 1000.0)
    assert np.array_equal(p[:2], p0[:2]) and np.array_equal(rho[:2], rho0[:2])
    assert p[2] == 0.0 and rho[2] == 1000.0
    assert p[3] == p0[3] and rho[3] == rho0[3] and p[4] == 0.0


def test_clamped_walls_are_never_negative_and_adami_walls_are():
    """The solver applies the key: in a still tank the dummy particles above the water line,
    which see only the free surface's top rows, extrapolate a negative pressure under 'adami'
    (the hydrostatic term rho g . (r_w - r_f) < 0 above the fluid) and none under 'clamped'."""
    lows = {}
    for mode in ("adami", "clamped"):
        s = DeltaSPHSolver(_tank(wall_pressure=mode))
        for _ in range(3):
            s.step(s.dt_next)
        lows[mode] = float(s.p[s.n_fluid :].min())
    assert lows["adami"] < 0.0
    assert lows["clamped"] >= 0.0


def test_a_shaken_tank_carries_its_acceleration_into_the_dummy_pressure():
    """A tank shaken harmonically along x, x = A sin(2 pi t / T): over each step its particles
    carry a_w = (v(t + dt) - v(t)) / dt, which tends to -A (2 pi / T)^2 sin(2 pi t / T)."""
    a, period = 0.002, 0.5
    spec = FluidSection(
        method="delta-sph",
        spacing=0.02,
        blocks=[{"lower": [0.0, 0.0], "upper": [0.3, 0.2]}],
        walls=[
            {
                "shape": "tank",
                "lower": [0.0, 0.0],
                "upper": [0.3, 0.4],
                "motion": {"kind": "harmonic", "amplitude": a, "period": period},
            }
        ],
    )
    s = DeltaSPHSolver(spec)
    for _ in range(3):
        t0, dt = s.t, s.dt_next
        s.step(dt)
        w = 2 * np.pi / period
        exact = -a * w * w * np.sin(w * (t0 + 0.5 * dt))  # the mean over the step, to O(dt^2)
        assert np.allclose(s.wall_acc[:, 0], exact, rtol=1e-4)
        assert np.all(s.wall_acc[:, 1] == 0.0)


def test_a_damping_zone_limits_the_step_by_its_viscosity():
    """With a sponge zone the ramp's alpha = 0.6 sets dt <= 0.15 h / (0.6 c0) under RK4 (at
    0.8 h / c0 the regular-wave tank's zone blew up within 15 steps, docs/fluid_sph.md)."""
    spec = _tank()
    zone = {"axis": 0, "start": 0.2, "end": 0.3}
    s = DeltaSPHSolver(spec.model_copy(update={"sponges": [SpongeZone(**zone)]}))
    assert s.alpha_max == 0.6
    assert s.dt_next <= 0.15 * s.h / (0.6 * s.c0) * (1 + 1e-12)
    assert DeltaSPHSolver(_tank()).dt_next > 0.5 * s.h / s.c0  # no zone: the acoustic limit


def _reference_rhs(s):
    """acc, drho/dt, M and <grad rho> of the fluid written out from the seed's equations with
    numpy, row by row over the solver's neighbour list (p, rho of the walls and V as the solver
    set them): Huang et al. 2022 eqs. 2, 3, 6, 7, 12, 13; W' from ``gradient_factor``."""
    nf, dim, h = s.n_fluid, s.dim, s.h
    nb = build_neighbours(s.pos, s.radius)  # the exact list, built afresh
    vol = s.mass / s.rho
    rows = [nb.indices[nb.indptr[i] : nb.indptr[i + 1]] for i in range(nf)]
    grads, M, grad_rho = [], np.zeros((nf, dim, dim)), np.zeros((nf, dim))
    for i, j in enumerate(rows):
        rij = s.pos[i] - s.pos[j]
        r = np.linalg.norm(rij, axis=1)
        gw = np.array([gradient_factor(x, h, s.norm) for x in r])[:, None] * rij * vol[j, None]
        grads.append(gw)
        b = -(rij[:, :, None] * gw[:, None, :]).sum(axis=0)  # sum_j (r_j - r_i) (x) grad W V_j
        M[i] = np.linalg.inv(b) if np.linalg.det(b) > delta_sph.DET_MIN else np.eye(dim)
        grad_rho[i] = M[i] @ ((s.rho[j] - s.rho[i])[:, None] * gw).sum(axis=0)  # eq. 7
    acc, drho = np.zeros((nf, dim)), np.zeros(nf)
    for i, j in enumerate(rows):
        gw, rij = grads[i], s.pos[i] - s.pos[j]
        fl = j < nf
        uji = s.vel[j] - s.vel[i]
        div = (uji * gw).sum()
        if s.corrected:  # eq. 12, M_j = M_i at a wall
            mj = np.where(fl[:, None, None], M[np.minimum(j, nf - 1)], M[i])
            a = s.p[i] * M[i] + s.p[j, None, None] * mj
            gp = np.einsum("kab,kb->a", a, gw)
        else:  # eq. 6
            gp = ((s.p[i] + s.p[j])[:, None] * gw).sum(axis=0)
        jf, rf, gf, uf = j[fl], rij[fl], gw[fl], uji[fl]
        r2 = (rf * rf).sum(axis=1)
        den = r2 + 0.01 * h * h
        psi = s.rho[jf] - s.rho[i] + 0.5 * ((grad_rho[i] + grad_rho[jf]) * rf).sum(axis=1)
        diff = (psi * -(rf * gf).sum(axis=1) / den).sum()  # sum psi_ji (r_j - r_i).grad W V_j
        phi = -2.0 * (dim + 2) * (uf * rf).sum(axis=1) / den  # eq. 3
        pi_visc = ((0.5 * (s.alpha[i] + s.alpha[jf]) * phi)[:, None] * gf).sum(axis=0)
        drho[i] = -s.rho[i] * div + s.sph.density_diffusion * h * s.c0 * 2.0 * diff  # eqs. 1, 2
        acc[i] = (-gp / s.rho[i] + s.gravity - s.omega2 * (s.pos[i] - s.center)
                  + h * s.c0 * s.rho0 / s.rho[i] * pi_visc)  # fmt: skip
    return acc, drho, M, grad_rho


@pytest.mark.parametrize(
    ("dim", "gradient"), [(2, "corrected"), (2, "plain"), (3, "corrected"), (3, "plain")]
)
def test_kernels_follow_the_seed_equations(dim, gradient):
    """The per-dimension kernels (cached F V_j per pair, p_i M_i per particle) against the seed's
    equations written out with numpy: a tank with walls, jittered, with random velocities and
    densities, so that every term (walls, diffusion, viscosity; in 3D the correction's identity
    fallback at 5 corner particles) is non-zero. Agreement to 1e-12 of each array's largest
    entry: the two differ only in summation order and W' evaluation (measured 4e-16 - 8e-16)."""
    lo, up = [0.0] * dim, [0.2] + [0.12] * (dim - 1)
    spec = FluidSection(
        method="delta-sph",
        dim=dim,
        spacing=0.02,
        gravity=[0.0] * (dim - 1) + [-9.81],
        blocks=[{"lower": lo, "upper": up}],
        walls=[{"shape": "tank", "lower": lo, "upper": [0.2] + [0.2] * (dim - 1), "name": "t"}],
        sph={"gradient": gradient, "viscosity_alpha": 0.1},
    )
    s = DeltaSPHSolver(spec)
    nf = s.n_fluid
    rng = np.random.default_rng(3)
    s.pos[:nf] += 0.2 * 0.02 * rng.uniform(-1, 1, (nf, dim))
    s.vel[:nf] = rng.uniform(-0.5, 0.5, (nf, dim))
    s.rho[:nf] *= 1.0 + 0.005 * rng.uniform(-1, 1, nf)
    s.rhs()
    acc, drho, M, grad_rho = _reference_rhs(s)
    for got, want in ((s.acc[:nf], acc), (s.drho[:nf], drho), (s.M, M), (s.grad_rho, grad_rho)):
        assert np.abs(got - want).max() <= 1e-12 * np.abs(want).max()
    assert np.array_equal(s.pM, s.p[:nf, None, None] * s.M)


def _collapse(**sph):
    """A small dam break (0.1 x 0.2 m column in a 0.4 m tank, l0 = 0.01 m): a flow that moves
    the particles enough to rebuild the Verlet candidates in 60 RK4 steps."""
    return FluidSection(
        method="delta-sph",
        spacing=0.01,
        blocks=[{"lower": [0.0, 0.0], "upper": [0.1, 0.2]}],
        walls=[{"shape": "tank", "lower": [0.0, 0.0], "upper": [0.4, 0.3], "name": "tank"}],
        sph=sph,
    )


@pytest.mark.parametrize("integrator", ["rk4", "symplectic"])
def test_candidate_rows_give_the_exact_lists_bits(integrator):
    """The kernels on the Verlet candidates (pairs beyond the radius skipped inside them) and on
    the exact neighbour list of the shared search (the path of coupled runs and of the momentum
    budget) give the same state, bit for bit, over 60 RK4 or 300 leapfrog steps of a collapsing column."""
    spec = _collapse(integrator=integrator)
    fast = DeltaSPHSolver(spec)
    exact = DeltaSPHSolver(spec)
    assert isinstance(fast.search, CandidatePairs) and not fast.exact_neighbours
    exact.exact_neighbours = True
    exact.search = NeighbourSearch(2, exact.radius, domain=(exact.lower, exact.upper),
                                   skin=spec.neighbours.skin * spec.spacing)  # fmt: skip
    for _ in range(60 if integrator == "rk4" else 300):  # the leapfrog's dt is 8 times shorter
        fast.step(fast.dt_next)
        exact.step(exact.dt_next)
    assert fast.search.builds > 1 and fast.search.reuses > fast.search.builds
    for k, v in fast.state().items():
        assert np.array_equal(v, exact.state()[k]), k


def test_candidate_pairs_hold_every_neighbour_until_a_rebuild():
    """CandidatePairs: each row ascending and a superset of the exact list; reused while no
    particle has moved more than skin / 2, rebuilt beyond; rebuilt at the radius itself (exact)
    when particles move more than skin / 4 per call."""
    rng = np.random.default_rng(5)
    pos = rng.uniform(0.0, 1.0, (400, 2))
    radius, skin = 0.1, 0.02
    pairs = CandidatePairs(2, radius, skin)

    def check(nb):
        exact = build_neighbours(pos, radius)
        for i in range(len(pos)):
            row = nb.indices[nb.indptr[i] : nb.indptr[i + 1]]
            assert np.all(np.diff(row) > 0)
            assert set(exact.indices[exact.indptr[i] : exact.indptr[i + 1]]) <= set(row)

    check(pairs.update(pos))
    assert (pairs.builds, pairs.reuses) == (1, 0)
    start = pos.copy()
    pos += 0.4 * skin * rng.uniform(-1, 1, pos.shape) / np.sqrt(2)  # |move| < 0.4 skin
    check(pairs.update(pos))
    assert (pairs.builds, pairs.reuses) == (1, 1)
    pos[7] = start[7] + [0.6 * skin, 0.0]  # particle 7 has moved more than skin / 2
    nb = pairs.update(pos)  # rebuilt; 0.3 skin per call since the last build: the exact list
    assert pairs.builds == 2 and not pairs._valid
    assert np.array_equal(nb.indices, build_neighbours(pos, radius).indices)
    for _ in range(7):  # slow particles (0.09 skin per call): candidates again, for 5 calls
        check(pairs.update(pos))
        pos += [0.09 * skin, 0.0]
    assert (pairs.builds, pairs.reuses) == (4, 6) and pairs._valid


def test_a_step_allocates_no_particle_arrays():
    """After the first steps, 40 RK4 steps of a collapsing column (a Verlet rebuild among them)
    allocate at their peak less than half of one float64 array over the particles, 19 kB here
    (measured 4.4 kB alone, the same at 632, 1632 and 4832 particles: the rebuild's grid
    bookkeeping; 6.8 kB within the test session)."""
    s = DeltaSPHSolver(_collapse().model_copy(update={"spacing": 0.0025}))
    for _ in range(5):
        s.step(s.dt_next)
    builds = s.search.builds
    tracemalloc.start()
    try:
        base = tracemalloc.get_traced_memory()[0]
        for _ in range(40):
            s.step(s.dt_next)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert s.search.builds > builds
    assert peak - base < 8 * s.n / 2
