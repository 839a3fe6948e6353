"""Khayyer & Gotoh's remedies for pressure noise behind their [fluid.pressure] switches: the
higher-order Laplacian (HL), the higher-order source term (HS) and the error-compensating source
term (ECS), each against a reference with the method's expected error."""

import numpy as np
import pytest
from conftest import interior_mask, square_lattice, tank

from mpsfem.fluid_mps import operators as ops
from mpsfem.fluid_mps.higher_order_laplacian import (
    hl_constants,
    hl_shape,
    hl_shape_py,
    laplacian_code,
)
from mpsfem.fluid_mps.kernels import weight_py
from mpsfem.fluid_mps.lattice import lattice_constants, lattice_offsets
from mpsfem.fluid_mps.neighbours import NeighbourSearch
from mpsfem.fluid_mps.particle_kinds import FLUID
from mpsfem.fluid_mps.pressure_poisson import make_pressure_solver
from mpsfem.fluid_mps.source_terms import (
    add_error_compensation,
    hs_source,
    number_density_rate,
    rate_constant,
)
from mpsfem.fluid_mps.surface import make_surface_detector

L0 = 0.01
RHO, G, DT = 1000.0, 9.81, 1e-3
RE_N = 2.1 * L0


# ----------------------------------------------------------------------------- HL
@pytest.mark.parametrize("kernel", ["improved", "original"])
@pytest.mark.parametrize("dim", [2, 3])
def test_hl_pair_function_numba_matches_numpy_and_is_positive(kernel, dim):
    re = 4.01
    r = np.linspace(0.05, 4.2, 300)
    code = 0 if kernel == "improved" else 1
    got = np.array([hl_shape(x, re, code, dim) for x in r])
    np.testing.assert_allclose(got, hl_shape_py(r, re, kernel, dim), rtol=1e-14)
    assert np.all(got[r < re] > 0.0) and np.all(got[r >= re] == 0.0)
    if kernel == "original":  # Khayyer & Gotoh's closed forms: 3 re / r^3 (2D), 2 re / r^3 (3D)
        np.testing.assert_allclose(got[r < re], (5 - dim) * re / r[r < re] ** 3, rtol=1e-13)


@pytest.mark.parametrize(
    ("dim", "wall_model"), [(2, "pressure_layer"), (2, "neumann"), (3, "neumann")]
)
def test_hl_matrix_gives_exact_laplacian_of_a_quadratic_field(dim, wall_model):
    """Rows of the assembled matrix whose neighbours are all unknowns, on the regular lattice:
    -(A phi)_i = lap phi = 2 (1 + 2 + 3) for phi = x^2 + 2 y^2 (+ 3 z^2) (the lattice
    normalisation makes the quadratic exact, as lambda0 does for eq. 2-16); the standard
    Laplacian likewise. 3D on the 3.1 l0 radius (a smaller test lattice)."""
    size, re = (30, 4.01) if dim == 2 else (13, 3.1)
    pos, kind = tank((size,) * dim, L0, layers=4, air_rows=3)
    nb = NeighbourSearch(dim, re * L0).build(pos)
    n = np.empty(len(pos))
    ops.number_density(pos, nb.indptr, nb.indices, RE_N, 0, n)
    fs = np.zeros(len(pos), np.int8)
    det = make_surface_detector("density_asymmetry", dim=dim, l0=L0, re=RE_N)
    det.detect(pos, kind, n, nb, fs)
    vel = np.zeros_like(pos)
    coef = np.arange(1, dim + 1, dtype=float)
    phi = (pos**2) @ coef
    margin = np.ceil(re) + 1
    inner = (kind == FLUID) & interior_mask(pos, [0] * dim, [(size - 1) * L0] * dim, margin * L0)
    assert inner.sum() >= (27 if dim == 3 else 100)
    g = np.zeros(dim)
    g[-1] = -G
    for lap in ("standard", "higher_order"):
        s = make_pressure_solver(
            "pcg_jacobi",
            dim=dim,
            l0=L0,
            re=re * L0,
            re_density=RE_N,
            gamma=0.0,
            laplacian=lap,
            wall_model=wall_model,
            gravity=g,
        )
        A, _, m = s.assemble(pos, vel, kind, n, fs, nb, DT)
        x = np.zeros(m)
        x[s.row_of[s.unknown == 1]] = phi[s.unknown == 1]
        lap_phi = -(A @ x)[s.row_of[inner]]
        np.testing.assert_allclose(lap_phi, 2.0 * coef.sum(), rtol=1e-9)


@pytest.mark.parametrize("kernel", ["improved", "original"])
def test_hl_converges_at_second_order_on_the_regular_lattice(kernel):
    """A non-polynomial field: the error of both Laplacians at a point falls by 4 per halving of
    l0 (the quartic terms of the Taylor series; observed order 2 +- 0.1), HL's within 1.5 times
    the standard one's. (On a randomly perturbed lattice neither converges: the jitter's first-
    order terms do not cancel, an O(1) error for either; docs/fluid.md.)"""
    x0 = np.array([0.1, 0.2])

    def phi(p):
        return np.sin(p[..., 0] + 0.3) * np.cos(0.7 * p[..., 1])

    exact = -1.49 * phi(x0)
    err_std, err_hl = [], []
    for h in (0.2, 0.1, 0.05):
        re = 4.01 * h
        pts = lattice_offsets(2, h, re)
        r = np.sqrt((pts**2).sum(axis=1))
        d = phi(x0 + pts) - phi(x0)
        n0, lam = lattice_constants(2, h, re, kernel)
        c_hl, _ = hl_constants(2, h, re, kernel)
        err_std.append(abs(4.0 / (lam * n0) * (weight_py(r, re, kernel) * d).sum() - exact))
        err_hl.append(abs(c_hl * (hl_shape_py(r, re, kernel, 2) * d).sum() - exact))
    for e in (err_std, err_hl):
        order = np.log2(np.array(e[:-1]) / np.array(e[1:]))
        np.testing.assert_allclose(order, 2.0, atol=0.1)
    assert max(np.array(err_hl) / np.array(err_std)) < 1.5


def test_unknown_laplacian_and_source_are_refused():
    kw = dict(dim=2, l0=1.0, re=4.01, re_density=2.1)
    with pytest.raises(ValueError, match="unknown PPE Laplacian"):
        make_pressure_solver("direct", laplacian="fourth", **kw)
    with pytest.raises(ValueError, match="unknown source term"):
        make_pressure_solver("direct", source_term="hs", **kw)
    with pytest.raises(ValueError, match="gravity must have 2"):
        make_pressure_solver("direct", gravity=[0.0, 0.0, -9.81], **kw)
    assert laplacian_code("standard") == 0


# ----------------------------------------------------------------------------- HS
def _lattice(dim, n):
    pos = square_lattice(dim, n, L0)
    kind = np.zeros(len(pos), np.int8)
    nb = NeighbourSearch(dim, 4.01 * L0).build(pos)
    inner = interior_mask(pos, [0] * dim, [(n - 1) * L0] * dim, 3 * L0)
    return pos, kind, nb, inner


@pytest.mark.parametrize("dim", [2, 3])
def test_hs_rate_is_the_number_density_derivative_and_exact_divergence(dim):
    """A linear velocity field u = G x (G with shear and rotation): the HS rate Dn/Dt is the
    time derivative of the number density under that motion (central difference of eq. 2-5 at
    x +- dt G x, O(dt^2)), and the HS divergence -(1/nu0) Dn/Dt equals tr G to round-off on
    the lattice's interior; the source (gamma = 0) is rho / dt tr G."""
    rng = np.random.default_rng(3)
    pos, kind, nb, inner = _lattice(dim, 12 if dim == 2 else 9)
    Gm = rng.normal(0.0, 1.0, (dim, dim))
    vel = pos @ Gm.T
    dry = np.zeros(len(pos), np.int8)
    nk, rate = np.empty(len(pos)), np.empty(len(pos))
    g = np.zeros(dim)
    number_density_rate(
        pos, vel, kind, dry, nb.indptr, nb.indices, RE_N, 0, False, g, DT, 0.0, nk, rate
    )
    h = 1e-5
    npl, nmi = np.empty(len(pos)), np.empty(len(pos))
    ops.number_density(pos + h * vel, nb.indptr, nb.indices, RE_N, 0, npl)
    ops.number_density(pos - h * vel, nb.indptr, nb.indices, RE_N, 0, nmi)
    fd = (npl - nmi) / (2 * h)
    scale = np.abs(rate[inner]).max()
    np.testing.assert_allclose(rate[inner], fd[inner], atol=1e-6 * scale)
    n0, _ = lattice_constants(dim, L0, RE_N)
    np.testing.assert_allclose(nk[inner], n0, rtol=1e-12)
    nu0 = rate_constant(dim, L0, RE_N)
    np.testing.assert_allclose(-rate[inner] / nu0, np.trace(Gm), rtol=1e-10, atol=1e-12)
    out = np.empty(len(pos))
    hs_source(
        pos,
        vel,
        kind,
        dry,
        nb.indptr,
        nb.indices,
        RE_N,
        0,
        False,
        g,
        DT,
        nu0,
        n0,
        nk,
        RHO,
        0.0,
        out,
    )
    np.testing.assert_allclose(out[inner], RHO / DT * np.trace(Gm), rtol=1e-10, atol=1e-6)


def test_hs_neumann_takes_the_standard_wall_flux_back_out():
    """With the Neumann model the caller's right-hand side holds the wall flux in the standard
    form (eq. 2-15 over wet boundary neighbours at u_w + g dt, wall_boundary.ghost_rhs); the HS
    source is (1 - gamma) rho / dt times the HS divergence over all neighbours (boundary ghosts at
    u_w + g dt) minus exactly that standard part. Water at rest before gravity acts (u* = 0)
    sees a flux through the floor."""
    pos, kind = tank((12, 8), L0, layers=4, air_rows=3)
    nb = NeighbourSearch(2, 4.01 * L0).build(pos)
    vel = np.zeros_like(pos)
    n = np.empty(len(pos))
    ops.number_density(pos, nb.indptr, nb.indices, RE_N, 0, n)
    n0, _ = lattice_constants(2, L0, RE_N)
    dry = np.zeros(len(pos), np.int8)
    g = np.array([0.0, -G])
    nu0 = rate_constant(2, L0, RE_N)
    out = np.empty(len(pos))
    args = (nb.indptr, nb.indices, RE_N, 0, True, g, DT)
    hs_source(pos, vel, kind, dry, *args, nu0, n0, n, RHO, 0.0, out)
    nk, rate = np.empty(len(pos)), np.empty(len(pos))
    number_density_rate(pos, vel, kind, dry, *args, 0.0, nk, rate)
    fl = kind == FLUID
    vg = vel.copy()
    vg[~fl] += g * DT
    full, only_fluid = np.empty(len(pos)), np.empty(len(pos))
    ops.divergence(pos, vg, kind, nb.indptr, nb.indices, RE_N, 0, n0, full, False)
    ops.divergence(pos, vg, kind, nb.indptr, nb.indices, RE_N, 0, n0, only_fluid, True)
    wall_std = full - only_fluid
    assert np.abs(wall_std[fl]).max() > 0.1  # 1/s: the floor rows do see a wall flux
    expect = RHO / DT * (-rate / nu0 - wall_std)
    np.testing.assert_allclose(out[fl], expect[fl], rtol=1e-10, atol=1e-9 * RHO / DT)
    assert np.allclose(out[fl & (pos[:, 1] > 3 * L0)], 0.0)  # away from the walls: no flux


# ----------------------------------------------------------------------------- ECS
def test_ecs_vanishes_on_an_unperturbed_lattice_and_restores_a_compressed_one():
    """Whatever the velocities, a step that starts on the unperturbed lattice (x* - dt u* on it)
    has n^k = n0, so both ECS terms vanish (to round-off against the scale rho / (n0 dt) |Dn/Dt|).
    A compressed start (lattice shrunk by 1 %) gives n^k > n0 and a negative (compressive-
    restoring) ECS, the sign of the density term of eq. 2-23."""
    rng = np.random.default_rng(7)
    pos0, kind, nb, inner = _lattice(2, 14)
    vel = rng.normal(0.0, 0.5, pos0.shape)
    pos = pos0 + DT * vel
    dry = np.zeros(len(pos), np.int8)
    g = np.zeros(2)
    nk, rate = np.empty(len(pos)), np.empty(len(pos))
    nb2 = NeighbourSearch(2, 4.01 * L0).build(pos)
    number_density_rate(
        pos, vel, kind, dry, nb2.indptr, nb2.indices, RE_N, 0, False, g, DT, 1.0, nk, rate
    )
    n0, _ = lattice_constants(2, L0, RE_N)
    np.testing.assert_allclose(nk[inner], n0, rtol=1e-12)
    out = np.zeros(len(pos))
    add_error_compensation(nk, rate, kind, RHO, DT, n0, out)
    scale = RHO / (n0 * DT) * np.abs(rate[inner]).max()
    assert np.abs(out[inner]).max() < 1e-9 * scale
    # compressed by 1 % and still converging (u = -x / (1 s)): both terms negative
    pos_c = 0.99 * pos0
    vel_c = -pos_c * 1.0
    pos_c = pos_c + DT * vel_c
    nb3 = NeighbourSearch(2, 4.01 * L0).build(pos_c)
    number_density_rate(
        pos_c, vel_c, kind, dry, nb3.indptr, nb3.indices, RE_N, 0, False, g, DT, 1.0, nk, rate
    )
    assert np.all(nk[inner] > n0) and np.all(rate[inner] > 0)
    out[:] = 0.0
    add_error_compensation(nk, rate, kind, RHO, DT, n0, out)
    assert np.all(out[inner] < 0.0)
    strain = (nk - n0) / n0
    expect = -abs(strain) * RHO / (n0 * DT) * rate - abs(DT * rate / n0) * RHO / DT**2 * strain
    np.testing.assert_allclose(out[inner], expect[inner], rtol=1e-12)


# ----------------------------------------------------------------------------- still water
RUN_END = 1.0


def _still_water_gauge(root, overrides):
    from mpsfem.fluid_mps.solver import FluidSolver
    from mpsfem.scenario.loader import load_scenario

    sc = load_scenario(root / "scenarios" / "hydrostatic_2d.toml", overrides).scenario
    solver = FluidSolver(sc.fluid)
    values = []
    while solver.t < RUN_END - 1e-12:
        solver.step(solver.dt_towards(RUN_END))
        if solver.t >= 0.5:
            values.append(solver.probe_value(sc.probes[0]))
    return float(np.mean(values))


@pytest.mark.parametrize(
    "switches",
    [
        ["fluid.pressure.source_term=higher_order"],
        ["fluid.pressure.source_term=higher_order", "fluid.pressure.error_compensation=true"],
        ["fluid.pressure.laplacian=higher_order"],
        ["fluid.pressure.error_compensation=true"],
    ],
    ids=["HS", "HS+ECS", "HL", "ECS"],
)
def test_still_water_stays_hydrostatic_with_each_switch(request, switches):
    """Still water (scenarios/hydrostatic_2d.toml, 1 s) with a remedy switched on: the gauge's
    mean over 0.5-1 s within 2 % of rho g (H - 0.05), the hydrostatic test's tolerance."""
    expected = RHO * G * (0.5 - 0.05)
    mean = _still_water_gauge(request.config.rootpath, switches)
    print(
        f"{switches}: gauge {mean:.1f} Pa vs {expected:.1f} ({(mean / expected - 1) * 100:+.2f} %)"
    )
    assert abs(mean / expected - 1.0) < 0.02


@pytest.mark.parametrize(
    "switches",
    [
        ["fluid.pressure.laplacian=higher_order"],
        ["fluid.pressure.source_term=higher_order", "fluid.pressure.error_compensation=true"],
    ],
    ids=["HL", "HS+ECS"],
)
def test_still_water_3d_stays_hydrostatic_with_each_switch(request, tmp_path, switches):
    """The 3D path (HL's 3D pair function w'', Khayyer & Gotoh 2012): the CI still-water box of
    tests/scenarios/test_hydrostatic_3d.py (8 x 8 x 10 particles, 0.2 s), gauge mean over
    0.05-0.2 s within its 2 % of rho g (H - z). Measured: HL +0.03 %, HS+ECS -1.1 % (default
    +0.07 %)."""
    import h5py

    from mpsfem.scenario.loader import load_scenario
    from mpsfem.simulation import run_fluid

    loaded = load_scenario(
        request.config.rootpath / "scenarios" / "hydrostatic_3d.toml",
        [
            "fluid.blocks.0.upper=[0.08, 0.08, 0.1]",
            "fluid.walls.0.upper=[0.08, 0.08, 0.16]",
            "probes.0.position=[0.04, 0.04, 0.03]",
            "output.snapshot_interval=0",
            *switches,
        ],
    )
    out = tmp_path / "still3d.h5"
    run_fluid(loaded, out, end_time=0.2, progress=False)
    with h5py.File(out, "r") as h5:
        t = h5["probes/gauge/time"][:]
        p = h5["probes/gauge/value"][:]
    mean = p[t >= 0.05].mean()
    exact = RHO * G * (0.1 - 0.03)
    print(f"3D {switches}: gauge {mean:.1f} Pa against {exact:.1f} Pa")
    assert abs(mean / exact - 1.0) < 0.02


def _dam_break_steps(root, overrides, steps=20):
    from mpsfem.fluid_mps.solver import FluidSolver
    from mpsfem.scenario.loader import load_scenario

    over = ["fluid.spacing=0.0073", *overrides]  # L/20
    sc = load_scenario(root / "scenarios" / "dam_break_2d.toml", over).scenario
    solver = FluidSolver(sc.fluid)
    for _ in range(steps):
        solver.step(solver.dt_towards(1.0))
    return solver.pos.copy(), solver.p.copy()


def test_switches_off_are_the_default_and_each_switch_changes_the_step(request):
    """20 dam-break steps at L/20: the four keys set to their 'off' values give bit for bit the
    default run (the code before the switches gave it too: 40 steps at L/40 compared exactly when
    they were added), and each switch on changes the pressure."""
    root = request.config.rootpath
    pos0, p0 = _dam_break_steps(root, [])
    off = [
        "fluid.pressure.source_term=thesis_mixed",
        "fluid.pressure.error_compensation=false",
        "fluid.pressure.laplacian=standard",
        "fluid.pressure.source_filter=none",
    ]
    pos1, p1 = _dam_break_steps(root, off)
    assert np.array_equal(pos0, pos1) and np.array_equal(p0, p1)
    scale = np.abs(p0).max()
    for on in (
        "fluid.pressure.source_term=higher_order",
        "fluid.pressure.error_compensation=true",
        "fluid.pressure.laplacian=higher_order",
        "fluid.pressure.source_filter=kernel_average",
    ):
        _, p2 = _dam_break_steps(root, [on])
        assert np.abs(p2 - p0).max() > 1e-3 * scale, on
