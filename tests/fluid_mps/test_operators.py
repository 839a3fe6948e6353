"""Operators on a perfect lattice against analytic fields (interior particles with full support).

On a perfect lattice the odd moments of the neighbourhood vanish and sum_j r r^T w / r^2 = n0/d I,
sum_j r r^T w = n0 lambda0 / d I. Hence, at interior particles:
- gradient (Tanaka, p_min) and divergence of linear AND quadratic fields are exact;
- the Laplacian of a quadratic field is exact (lambda0 is the lattice's own second moment);
all up to round-off. The tolerance (1e-9 relative to the field's scale) allows for the round-off of
sums of ~50-300 terms of size |p| / l0 that cancel.
"""

import numba
import numpy as np
import pytest
from conftest import interior_mask, square_lattice

from mpsfem.fluid_mps import operators as ops
from mpsfem.fluid_mps.kernels import weight_code
from mpsfem.fluid_mps.lattice import lattice_constants
from mpsfem.fluid_mps.neighbours import build_neighbours
from mpsfem.fluid_mps.particle_kinds import DUMMY, FLUID, WALL

L0 = 0.1


def setup(dim, n, re_max):
    pos = square_lattice(dim, n, L0, origin=-0.5 * (n - 1) * L0)
    nl = build_neighbours(pos, re_max * L0)
    kind = np.zeros(len(pos), np.int8)
    lo, hi = pos.min(axis=0), pos.max(axis=0)
    return pos, nl, kind, lo, hi


def quad_field(pos, seed):
    rng = np.random.default_rng(seed)
    dim = pos.shape[1]
    a = rng.normal()
    b = rng.normal(size=dim)
    h = rng.normal(size=(dim, dim))
    h = 0.5 * (h + h.T)
    f = a + pos @ b + np.einsum("ni,ij,nj->n", pos, h, pos)
    grad = b + 2.0 * pos @ h
    return f, grad, 2.0 * np.trace(h), b


@pytest.mark.parametrize("dim,n", [(2, 14), (3, 9)])
@pytest.mark.parametrize("weight", ["improved", "original"])
def test_number_density_interior_equals_n0(dim, n, weight):
    re = 2.1
    pos, nl, kind, lo, hi = setup(dim, n, re)
    n0, _ = lattice_constants(dim, L0, re * L0, weight)
    out = np.empty(len(pos))
    ops.number_density(pos, nl.indptr, nl.indices, re * L0, weight_code(weight), out)
    inner = interior_mask(pos, lo, hi, 2 * L0)
    np.testing.assert_allclose(out[inner], n0, rtol=1e-12)
    assert np.all(out[~inner] < n0 - 1e-9)  # boundary particles miss neighbours


@pytest.mark.parametrize("dim,n", [(2, 14), (3, 9)])
@pytest.mark.parametrize("form", ["tanaka", "pmin", "corrected", "corrected_pmin"])
@pytest.mark.parametrize("order", ["linear", "quadratic"])
def test_pressure_gradient_exact_on_lattice(dim, n, form, order):
    re = 2.1
    pos, nl, kind, lo, hi = setup(dim, n, 4.01)  # shared list at a larger radius, filtered
    n0, _ = lattice_constants(dim, L0, re * L0)
    f, grad, _, b = quad_field(pos, seed=dim)
    if order == "linear":
        f = 3.0 + pos @ b
        grad = np.broadcast_to(b, pos.shape)
    out = np.empty_like(pos)
    ops.pressure_gradient(
        pos, f, kind, nl.indptr, nl.indices, re * L0, 0, n0, ops.gradient_code(form), True, out
    )
    inner = interior_mask(pos, lo, hi, 2 * L0)
    scale = np.abs(f).max() / L0
    np.testing.assert_allclose(out[inner], grad[inner], rtol=0, atol=1e-9 * scale)


@pytest.mark.parametrize("dim,n", [(2, 14), (3, 9)])
def test_divergence_exact_on_lattice(dim, n):
    re = 2.1
    pos, nl, kind, lo, hi = setup(dim, n, re)
    n0, _ = lattice_constants(dim, L0, re * L0)
    u = np.empty_like(pos)
    div = 0.0
    for c in range(dim):
        f, grad, _, _ = quad_field(pos, seed=10 + c)
        u[:, c] = f
        div = div + grad[:, c]
    out = np.empty(len(pos))
    ops.divergence(pos, u, kind, nl.indptr, nl.indices, re * L0, 0, n0, out)
    inner = interior_mask(pos, lo, hi, 2 * L0)
    np.testing.assert_allclose(out[inner], div[inner], rtol=0, atol=1e-9 * np.abs(u).max() / L0)


@pytest.mark.parametrize("dim,n", [(2, 14), (3, 11)])
@pytest.mark.parametrize("weight", ["improved", "original"])
def test_laplacian_quadratic_exact_on_lattice(dim, n, weight):
    re = 4.01 if dim == 2 else 3.1
    pos, nl, kind, lo, hi = setup(dim, n, re)
    n0, lam = lattice_constants(dim, L0, re * L0, weight)
    coef = ops.laplacian_coefficient(dim, n0, lam)
    f = np.empty((len(pos), 2))
    lap = np.empty(2)
    for c in range(2):
        f[:, c], _, lap[c], _ = quad_field(pos, seed=20 + c)
    out = np.empty_like(f)
    ops.laplacian(pos, f, kind, nl.indptr, nl.indices, re * L0, weight_code(weight), coef, out)
    inner = interior_mask(pos, lo, hi, np.ceil(re) * L0)
    assert inner.sum() > 0
    scale = np.abs(f).max() / L0**2
    expect = np.broadcast_to(lap, out[inner].shape)
    np.testing.assert_allclose(out[inner], expect, atol=1e-9 * scale)


def test_kind_handling_and_dummy_skip():
    dim, n, re = 2, 12, 2.1
    pos, nl, kind, lo, hi = setup(dim, n, re)
    n0, lam = lattice_constants(dim, L0, re * L0)
    kind[pos[:, 1] < lo[1] + 0.5 * L0] = DUMMY
    kind[np.abs(pos[:, 1] - (lo[1] + L0)) < 0.1 * L0] = WALL
    p = 1.0 + pos[:, 1] ** 2
    g = np.empty_like(pos)
    ops.pressure_gradient(pos, p, kind, nl.indptr, nl.indices, re * L0, 0, n0, 0, True, g)
    assert np.all(g[kind != FLUID] == 0.0)
    # a dummy's pressure is ignored when skipped, used when not
    p2 = p.copy()
    p2[kind == DUMMY] = 1e6
    g2 = np.empty_like(pos)
    ops.pressure_gradient(pos, p2, kind, nl.indptr, nl.indices, re * L0, 0, n0, 0, True, g2)
    np.testing.assert_array_equal(g, g2)
    ops.pressure_gradient(pos, p2, kind, nl.indptr, nl.indices, re * L0, 0, n0, 0, False, g2)
    assert np.any(g2 != g)
    div = np.empty(len(pos))
    ops.divergence(pos, pos.copy(), kind, nl.indptr, nl.indices, re * L0, 0, n0, div)
    assert np.all(div[kind == DUMMY] == 0.0)
    lap = np.empty_like(pos)
    ops.laplacian(pos, pos.copy(), kind, nl.indptr, nl.indices, re * L0, 0, 1.0, lap)
    assert np.all(lap[kind != FLUID] == 0.0)


@pytest.mark.parametrize("dim,n", [(2, 12), (3, 8)])
@pytest.mark.parametrize("form", ["corrected", "corrected_pmin", "pmin"])
def test_corrected_gradient_exact_for_linear_fields_at_boundaries(dim, n, form, rng):
    """Surface, edge and corner particles of a jittered block (truncated neighbourhoods): the
    corrected form gives the gradient of a linear field to round-off everywhere; the corrected
    p_min form wherever p_i is its neighbourhood's minimum (the top surface of a hydrostatic
    field; elsewhere it adds the repulsive (p_i - p_min) term by design); the plain p_min form
    misses up to half of it there, the reason a corrected form is the default (docs/fluid.md)."""
    re = 2.1
    pos, nl, kind, lo, hi = setup(dim, n, re)
    pos = pos + rng.uniform(-0.1, 0.1, size=pos.shape) * L0
    nl = build_neighbours(pos, re * L0)
    n0, _ = lattice_constants(dim, L0, re * L0)
    b = rng.normal(size=dim)
    f = 5.0 + (pos - pos.min(axis=0)) @ np.abs(b)  # >= 5 everywhere
    out = np.empty_like(pos)
    ops.pressure_gradient(
        pos, f, kind, nl.indptr, nl.indices, re * L0, 0, n0, ops.gradient_code(form), True, out
    )
    err = np.abs(out - np.abs(b)).max(axis=1) / np.abs(b).max()
    if form != "corrected":  # where p_i is the minimum of its neighbourhood
        lowest = np.array(
            [f[i] <= f[nl.indices[nl.indptr[i] : nl.indptr[i + 1]]].min() for i in range(len(f))]
        )
        assert 1 <= lowest.sum() < len(f)
        err = err[lowest]
    if form == "pmin":
        assert err.max() > 0.3  # truncated support: far from the field's gradient
    else:
        assert err.max() < 1e-10


def test_gradient_registry():
    assert ops.gradient_code("tanaka") == ops.TANAKA
    assert ops.gradient_code("pmin") == ops.PMIN
    with pytest.raises(ValueError, match="unknown pressure gradient form 'x'.*pmin, tanaka"):
        ops.gradient_code("x")


def test_thread_count_does_not_change_results(rng):
    pos = rng.uniform(0, 1, size=(2000, 2))
    nl = build_neighbours(pos, 0.05)
    kind = np.zeros(len(pos), np.int8)
    p = rng.uniform(0, 1, len(pos))
    n0, _ = lattice_constants(2, 0.02, 0.042)
    outs = []
    saved = numba.get_num_threads()
    try:
        for t in sorted({1, saved}):
            numba.set_num_threads(t)
            g = np.empty_like(pos)
            ops.pressure_gradient(pos, p, kind, nl.indptr, nl.indices, 0.042, 0, n0, 1, True, g)
            outs.append(g)
    finally:
        numba.set_num_threads(saved)
    for g in outs[1:]:
        np.testing.assert_array_equal(g, outs[0])
