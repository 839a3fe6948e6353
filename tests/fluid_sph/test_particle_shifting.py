"""δ+-SPH particle shifting (fluid.sph.shifting = "delta_plus", fluid_sph/particle_shifting.py)."""

from __future__ import annotations

import numba
import numpy as np
import pytest

from mpsfem.fluid_mps.geometry import ParticleSet
from mpsfem.fluid_sph.solver import DeltaSPHSolver
from mpsfem.scenario.base import InvalidValue
from mpsfem.scenario.fluid import FluidSection
from mpsfem.scenario.fluid_sph import DeltaSPHSection

DX = 0.1


def _block(n=16, jitter=0.0, seed=3, **sph):
    """An n x n square of fluid (spacing 0.1 m) without walls or gravity, c0 = 10 m/s, U = 1
    m/s (Ma = 0.1); ``jitter``: uniform random displacement up to jitter l0 per axis."""
    spec = FluidSection(
        method="delta-sph",
        spacing=DX,
        gravity=[0.0, 0.0],
        blocks=[{"lower": [0.0, 0.0], "upper": [n * DX, n * DX]}],
        sph={"sound_speed": 10.0, "reference_speed": 1.0, "shifting": "delta_plus", **sph},
    )
    g = (np.arange(n) + 0.5) * DX
    pos = np.stack(np.meshgrid(g, g, indexing="ij"), axis=-1).reshape(-1, 2)
    rng = np.random.default_rng(seed)
    pos += jitter * DX * rng.uniform(-1.0, 1.0, pos.shape)
    ps = ParticleSet(pos, np.zeros_like(pos), np.zeros(len(pos), np.int8), np.zeros_like(pos),
                     len(pos))  # fmt: skip
    return DeltaSPHSolver(spec, particles=ps)


def _interior(s, layers=4):
    """Fluid particles at least ``layers`` spacings inside the block's original edges."""
    x = s.pos[: s.n_fluid]
    lo, hi = layers * DX, s.pos[: s.n_fluid].max() - layers * DX + 0.5 * DX
    return np.all((x > lo) & (x < hi), axis=1)


def _tank(**sph):
    return FluidSection(
        method="delta-sph",
        spacing=0.02,
        blocks=[{"lower": [0.0, 0.0], "upper": [0.3, 0.2]}],
        walls=[{"shape": "tank", "lower": [0.0, 0.0], "upper": [0.3, 0.4], "name": "tank"}],
        sph={"shifting": "delta_plus", **sph},
    )


def _disorder(s, inner):
    """RMS over ``inner`` of the distance to the nearest neighbour, relative to its mean: 0 on
    a lattice."""
    pos = s.pos[: s.n_fluid]
    d = np.linalg.norm(pos[:, None, :] - pos[None, :, :], axis=2)
    np.fill_diagonal(d, np.inf)
    near = d.min(axis=1)[inner]
    return float(near.std() / near.mean())


def test_a_uniform_lattice_is_not_shifted():
    """Inside a square lattice sum_j [1 + R (W/W0)^n] grad W_ij V_j cancels pair by pair: the
    shift is zero to round-off (1e-12 l0 per step against 0.5 l0 per step that the same law
    gives a particle displaced by 0.1 l0, next test); velocities untouched."""
    s = _block()
    inner = _interior(s)
    dt = s.dt_next
    shift = s.shifting.compute(s, dt)
    assert np.abs(shift[inner]).max() < 1e-12 * DX
    assert s.shifting.lam[inner].min() > 0.95  # a full support
    vel = s.vel.copy()
    s.shifting.apply(s, dt)
    assert np.array_equal(s.vel, vel)  # positions only: momentum unchanged, bit for bit


def test_a_displaced_particle_is_pushed_back():
    """One interior particle moved by 0.1 l0: the shift points back towards its lattice site,
    a fraction of the displacement (linearised: 4 h U dt (1.65 / h^2 + R term) ~ 0.3-0.9 of
    it at CFL Ma = 0.08), and its neighbours move little."""
    s = _block()
    inner = np.nonzero(_interior(s))[0]
    k = inner[len(inner) // 2]
    eps = np.array([0.1 * DX, 0.0])
    s.pos[k] += eps
    shift = s.shifting.compute(s, 0.8 * s.h / s.c0)  # CFL = 0.8, Ma = 0.1
    back = -shift[k] @ eps / (eps @ eps)
    assert 0.2 < back < 1.0
    assert abs(shift[k, 1]) < 1e-12 * DX
    assert np.linalg.norm(shift[inner], axis=1).max() == pytest.approx(
        np.linalg.norm(shift[k]), rel=1e-12
    )


def test_a_perturbed_lattice_relaxes():
    """A lattice jittered by up to 0.2 l0 per axis, shifted 30 times at CFL Ma = 0.08 without
    any flow: the interior's nearest-neighbour spread falls to under half its start (a
    Fickian relaxation of the particle concentration)."""
    s = _block(jitter=0.2)
    inner = _interior(s)
    before = _disorder(s, inner)
    for _ in range(30):
        s.shifting.apply(s, 0.8 * s.h / s.c0)
    after = _disorder(s, inner)
    assert before > 0.1
    assert after < 0.5 * before


def test_a_free_surface_particle_is_not_shifted_across_the_surface():
    """Still-water tank (0.2 m, 10 particles per depth): the free-surface row has lambda ~ 0.5
    and is not shifted; the rows of the surface layer move along the surface only (no
    vertical component, to round-off) even with a jittered surface layer."""
    s = DeltaSPHSolver(_tank())
    nf = s.n_fluid
    rng = np.random.default_rng(5)
    top = s.pos[:nf, 1] > 0.14
    s.pos[:nf][top] += 0.1 * s.l0 * rng.uniform(-1.0, 1.0, (int(top.sum()), 2))
    shift = s.shifting.compute(s, s.dt_next)
    sh = s.shifting
    surface = sh.lam < sh.lam_surface
    assert surface.sum() >= 12  # the top row, about 15 particles
    assert np.all(shift[surface] == 0.0)
    layer = ~surface & top
    n = sh.normal[layer]
    assert np.abs(np.einsum("ij,ij->i", shift[layer], n)).max() < 1e-12 * s.l0
    assert np.abs(shift[layer]).max() > 1e-4 * s.l0  # it does shift along the surface


def test_walls_are_never_shifted():
    s = DeltaSPHSolver(_tank())
    walls = s.pos[s.n_fluid :].copy()
    s.pos[: s.n_fluid] += 0.05 * s.l0 * np.random.default_rng(2).uniform(-1, 1, (s.n_fluid, 2))
    s.shifting.apply(s, s.dt_next)
    assert np.array_equal(s.pos[s.n_fluid :], walls)


def test_the_shift_is_capped():
    s = _block(shifting_max=0.01)
    inner = np.nonzero(_interior(s))[0]
    s.pos[inner[10]] += [0.3 * DX, 0.0]
    shift = s.shifting.compute(s, 0.8 * s.h / s.c0)
    assert np.linalg.norm(shift, axis=1).max() == pytest.approx(0.01 * DX, rel=1e-12)


@pytest.mark.parametrize("integrator", ["rk4", "symplectic"])
def test_still_water_with_shifting_keeps_hydrostatic_pressure(integrator):
    """The tank of test_delta_sph's still-water test with shifting on, 0.1 s: the bottom row's
    pressure within 1 % of rho g (d - y), no current beyond 5 % of sqrt(g d)."""
    s = DeltaSPHSolver(_tank(integrator=integrator))
    t_end = 0.1
    while s.t < t_end - 1e-12:
        s.step(s.dt_towards(t_end))
    nf = s.n_fluid
    bottom = s.pos[:nf, 1] < 0.02
    expected = 1000.0 * 9.81 * (0.2 - s.pos[:nf, 1][bottom])
    assert s.p[:nf][bottom].mean() == pytest.approx(expected.mean(), rel=0.01)
    assert np.abs(s.vel[:nf]).max() < 0.05 * np.sqrt(9.81 * 0.2)
    assert s.shifting.seconds > 0.0


@pytest.mark.parametrize("integrator", ["rk4", "symplectic"])
def test_restart_with_shifting_is_bit_identical(integrator):
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


def test_shifting_changes_the_run_and_none_is_the_old_one():
    """'none' (the default) steps exactly as a scenario without the key; 'delta_plus' differs."""
    base = FluidSection(**{**_tank().model_dump(exclude_unset=True), "sph": {}})
    off = DeltaSPHSolver(base)
    none = DeltaSPHSolver(base.model_copy(update={"sph": DeltaSPHSection(shifting="none")}))
    on = DeltaSPHSolver(_tank())
    for s in (off, none, on):
        for _ in range(5):
            s.step(s.dt_next)
    assert np.array_equal(off.pos, none.pos) and off.shifting is None
    assert not np.array_equal(off.pos, on.pos)


@pytest.mark.skipif(numba.config.NUMBA_NUM_THREADS < 2, reason="needs 2 numba threads")
def test_shifting_does_not_depend_on_the_thread_count():
    states = []
    for threads in (1, 2):
        numba.set_num_threads(threads)
        try:
            s = DeltaSPHSolver(_tank())
            s.pos[: s.n_fluid] += (
                0.05 * s.l0 * np.random.default_rng(4).uniform(-1, 1, (s.n_fluid, 2))
            )
            for _ in range(5):
                s.step(s.dt_next)
        finally:
            numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
        states.append(s.pos.copy())
    assert np.array_equal(states[0], states[1])


def test_3d_lattice_is_not_shifted_and_relaxes():
    n = 9
    spec = FluidSection(
        method="delta-sph",
        dim=3,
        spacing=DX,
        gravity=[0.0, 0.0, 0.0],
        blocks=[{"lower": [0.0, 0.0, 0.0], "upper": [n * DX] * 3}],
        sph={"sound_speed": 10.0, "reference_speed": 1.0, "shifting": "delta_plus"},
    )
    g = (np.arange(n) + 0.5) * DX
    pos = np.stack(np.meshgrid(g, g, g, indexing="ij"), axis=-1).reshape(-1, 3)
    ps = ParticleSet(pos, np.zeros_like(pos), np.zeros(len(pos), np.int8), np.zeros_like(pos),
                     len(pos))  # fmt: skip
    s = DeltaSPHSolver(spec, particles=ps)
    inner = np.all((pos > 3 * DX) & (pos < (n - 3) * DX), axis=1)
    shift = s.shifting.compute(s, 0.8 * s.h / s.c0)
    assert np.abs(shift[inner]).max() < 1e-12 * DX
    assert s.shifting.lam[inner].min() > 0.95
    corner = np.all(pos < DX, axis=1)
    assert s.shifting.lam[corner].max() < s.shifting.lam_surface  # a corner is on the surface
    k = np.nonzero(inner)[0][0]
    s.pos[k] += [0.1 * DX, 0.0, 0.0]
    shift = s.shifting.compute(s, 0.8 * s.h / s.c0)
    assert shift[k, 0] < 0.0 and abs(shift[k, 1]) < 1e-12 * DX


@pytest.mark.parametrize(
    ("keys", "match"),
    [
        ({"shifting_r": 0.3}, "shifting_r = 0.3: is read only with shifting = 'delta_plus'"),
        (
            {"shifting": "delta_plus", "shifting_surface": 0.8, "shifting_layer": 0.7},
            "shifting_layer = 0.7: must exceed shifting_surface = 0.8",
        ),
    ],
)
def test_shifting_keys_are_checked(keys, match):
    with pytest.raises((InvalidValue, ValueError), match=match):
        DeltaSPHSection(**keys)


def test_shifting_without_a_speed_is_refused():
    spec = FluidSection(
        method="delta-sph",
        spacing=DX,
        gravity=[0.0, 0.0],
        blocks=[{"lower": [0.0, 0.0], "upper": [DX * 8, DX * 8]}],
        sph={"sound_speed": 10.0, "shifting": "delta_plus"},
    )
    with pytest.raises(ValueError, match="reference_speed"):
        DeltaSPHSolver(spec)


def test_taylor_density_follows_a_linear_field():
    """shifting_density = 'taylor': rho_i += dr_i . <grad rho>_i with the CSPM gradient, exact
    for a linear density field (a displaced interior particle, its neighbours on the field);
    'keep' leaves rho alone."""
    for mode in ("keep", "taylor"):
        s = _block(shifting_density=mode)
        inner = np.nonzero(_interior(s))[0]
        k = inner[len(inner) // 2]
        s.pos[k] += [0.1 * DX, 0.05 * DX]
        grad = np.array([3.0, -2.0])  # kg/m^4
        s.rho[: s.n_fluid] = 1000.0 + s.pos[: s.n_fluid] @ grad
        rho = s.rho.copy()
        s.shifting.apply(s, 0.8 * s.h / s.c0)
        moved = s.shifting.shift[k]
        assert np.linalg.norm(moved) > 0.01 * DX
        expected = rho[k] + (moved @ grad if mode == "taylor" else 0.0)
        assert s.rho[k] == pytest.approx(expected, abs=1e-12 * 1000.0)
