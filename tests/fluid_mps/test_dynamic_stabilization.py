"""Dynamic stabilisation (fluid_mps/dynamic_stabilization.py), the antisymmetric gradients'
time-step limit (``fluid.pressure.pressure_courant``) and why ``cmps`` cannot hold still water.

References: exact properties of the discrete formulas, so round-off tolerances:

- a fluid pair closer than r_DS is moved back to r_DS in one step, half each, with equal and
  opposite velocity changes (momentum conserved to round-off); wall neighbours and pairs beyond
  r_DS are not touched;
- the limit dt = C l0 / sqrt(2 p_max / rho) of solver.stable_dt at the hydrostatic start;
- on a perfect hydrostatic lattice the Tanaka form (eq. 2-12) gives rho g in the interior up to
  the lattice's O(l0^2) error (the first step measured 1.009 rho g), while the ``cmps`` form
  with per-particle minima (Khayyer & Gotoh 2008 eq. 9) gives 0: its shift sum p^_j r w / r^2 is
  the gradient of p^ = p - 2 rho g l0, i.e. the gradient itself (docs/fluid.md).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from mpsfem.fluid_mps.dynamic_stabilization import stabilise
from mpsfem.fluid_mps.kernels import weight_code
from mpsfem.fluid_mps.lattice import lattice_constants
from mpsfem.fluid_mps.neighbours import build_neighbours
from mpsfem.fluid_mps.operators import gradient_code, pressure_gradient
from mpsfem.fluid_mps.solver import FluidSolver
from mpsfem.scenario.loader import load_scenario

L0 = 0.01
ROOT = Path(__file__).resolve().parents[2]


def stabilised(pos, kind, alpha=0.9, dt=1e-3, vel=None):
    nb = build_neighbours(pos, 2.1 * L0)
    pos = pos.copy()
    vel = np.zeros_like(pos) if vel is None else vel.copy()
    stabilise(pos, vel, kind, nb.indptr, nb.indices, alpha * L0, dt, np.empty_like(pos))
    return pos, vel


@pytest.mark.parametrize("dim", [2, 3])
def test_close_pair_is_moved_back_to_the_distance_with_equal_and_opposite_changes(dim):
    rng = np.random.default_rng(dim)
    pos = np.zeros((2, dim))
    pos[1] = rng.normal(size=dim)
    pos[1] *= 0.6 * L0 / np.linalg.norm(pos[1])
    vel0 = rng.normal(size=(2, dim))
    new, vel = stabilised(pos, np.zeros(2, np.int8), vel=vel0)
    np.testing.assert_allclose(vel.sum(axis=0), vel0.sum(axis=0), rtol=0, atol=1e-13)
    assert np.linalg.norm(new[1] - new[0]) == pytest.approx(0.9 * L0, rel=1e-12)
    e = pos[1] / np.linalg.norm(pos[1])
    np.testing.assert_allclose(vel[1] - vel0[1], 0.5 * 0.3 * L0 / 1e-3 * e, rtol=1e-12)


def test_walls_and_distant_pairs_are_left_alone():
    pos = np.array([[0.0, 0.0], [0.5 * L0, 0.0], [5 * L0, 0.0], [5.95 * L0, 0.0]])
    kind = np.array([0, 1, 0, 0], np.int8)  # 0-1 fluid-wall (collision model's), 2-3 at 0.95 l0
    new, vel = stabilised(pos, kind)
    np.testing.assert_array_equal(new, pos)
    np.testing.assert_array_equal(vel, 0.0)


def test_cloud_keeps_its_momentum():
    rng = np.random.default_rng(7)
    pos = rng.uniform(0, 6 * L0, size=(60, 2))
    vel0 = rng.normal(size=(60, 2))
    _, vel = stabilised(pos, np.zeros(60, np.int8), vel=vel0)
    assert np.abs(vel - vel0).max() > 1.0  # pairs were pushed
    np.testing.assert_allclose(vel.sum(axis=0), vel0.sum(axis=0), rtol=0, atol=1e-11)


def test_pressure_courant_limits_the_step():
    sc = load_scenario(
        ROOT / "scenarios" / "hydrostatic_2d.toml",
        ["fluid.pressure.gradient=tanaka", "fluid.pressure.pressure_courant=0.25"],
    )
    s = FluidSolver(sc.scenario.fluid, ROOT / "scenarios")
    p_max = s.p[: s.n_fluid].max()
    assert p_max > 4000.0  # rho g H at the floor
    assert s.dt_next == pytest.approx(0.25 * s.l0 / np.sqrt(2.0 * p_max / s.rho), rel=1e-12)


@pytest.mark.parametrize(("form", "expected"), [("tanaka", 1.0), ("cmps", 0.0)])
def test_interior_hydrostatic_gradient(form, expected):
    n = 20
    xs, ys = np.meshgrid(np.arange(n) * L0, np.arange(n) * L0, indexing="ij")
    pos = np.column_stack([xs.ravel(), ys.ravel()])
    rho, g = 1000.0, 9.81
    p = rho * g * (n * L0 - pos[:, 1])
    kind = np.zeros(len(pos), np.int8)
    re = 2.1 * L0
    nb = build_neighbours(pos, re)
    n0, _ = lattice_constants(2, L0, re, "improved")
    out = np.zeros_like(pos)
    pressure_gradient(pos, p, kind, nb.indptr, nb.indices, re, weight_code("improved"), n0,
                      gradient_code(form), True, out)  # fmt: skip
    inner = np.all((pos > 3 * L0) & (pos < (n - 4) * L0), axis=1)
    np.testing.assert_allclose(out[inner, 0], 0.0, atol=1e-9 * rho * g)
    np.testing.assert_allclose(out[inner, 1] / (-rho * g), expected, atol=1e-9)


def lattice(n=12):
    xs, ys = np.meshgrid(np.arange(n) * L0, np.arange(n) * L0, indexing="ij")
    return np.column_stack([xs.ravel(), ys.ravel()])


def test_shifting_moves_a_displaced_particle_back_and_leaves_the_surface():
    from mpsfem.fluid_mps.particle_shifting import shift_particles

    pos = lattice()
    mid = 6 * 12 + 6
    pos[mid, 0] += 0.1 * L0  # towards its right neighbour
    surface = np.zeros(len(pos), np.int8)
    surface[pos[:, 1] > 10.5 * L0] = 1
    kind = np.zeros(len(pos), np.int8)
    re = 2.1 * L0
    nb = build_neighbours(pos, re)
    n0, _ = lattice_constants(2, L0, re, "improved")
    new = pos.copy()
    moved = shift_particles(new, kind, surface, nb.indptr, nb.indices, re,
                            weight_code("improved"), n0, 0.1, L0, 0.1 * L0,
                            np.empty_like(pos))  # fmt: skip
    assert 0.0 < moved <= 0.1 * L0
    assert new[mid, 0] < pos[mid, 0]  # back towards its site
    assert abs(new[mid, 1] - pos[mid, 1]) < 1e-12 * L0
    near_top = pos[:, 1] > 8.5 * L0  # surface rows and those with a surface neighbour
    np.testing.assert_array_equal(new[near_top], pos[near_top])


def test_shifting_leaves_particles_next_to_a_member():
    from mpsfem.fluid_mps.particle_shifting import shift_particles

    pos = lattice()
    kind = np.zeros(len(pos), np.int8)
    kind[pos[:, 0] < 0.5 * L0] = 3  # a one-layer member along x = 0: no dummies behind it
    mid = 6 * 12 + 6
    pos[mid, 0] += 0.1 * L0
    re = 2.1 * L0
    nb = build_neighbours(pos, re)
    n0, _ = lattice_constants(2, L0, re, "improved")
    new = pos.copy()
    shift_particles(new, kind, np.zeros(len(pos), np.int8), nb.indptr, nb.indices, re,
                    weight_code("improved"), n0, 0.1, L0, 0.1 * L0, np.empty_like(pos))  # fmt: skip
    beside = (kind == 0) & (pos[:, 0] < 2.5 * L0)  # a member particle within re
    np.testing.assert_array_equal(new[beside], pos[beside])
    assert new[mid, 0] < pos[mid, 0]  # the interior still shifts


def test_pressure_courant_restart_is_bit_identical():
    """The limit reads a decaying pressure peak: it is part of the checkpoint's meta."""
    sets = [
        "fluid.spacing=0.04",
        "fluid.pressure.gradient=tanaka",
        "fluid.pressure.pressure_courant=0.25",
        "fluid.pressure.dynamic_stabilization=0.9",
        "fluid.pressure.shifting=0.1",
    ]
    spec = load_scenario(ROOT / "scenarios" / "hydrostatic_2d.toml", sets).scenario.fluid
    whole = FluidSolver(spec, ROOT / "scenarios")
    first = FluidSolver(spec, ROOT / "scenarios")
    for solver in (whole, first):
        for _ in range(3):
            solver.step(solver.dt_next)
        solver.p_peak = 1e5  # as after an impact: the limit still holds the step down
    for _ in range(3):
        whole.step(whole.dt_next)
    second = FluidSolver(spec, ROOT / "scenarios")
    second.restore(
        {k: v.copy() for k, v in first.state().items()},
        first.meta(),
        first.preconditioner_state(),
    )
    for _ in range(3):
        second.step(second.dt_next)
    assert second.p_peak > 0.0
    np.testing.assert_array_equal(second.pos, whole.pos)
    np.testing.assert_array_equal(second.vel, whole.vel)
