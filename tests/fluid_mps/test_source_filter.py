"""The kernel average of the source term's divergence (fluid_mps/source_filter.py)."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import interior_mask, square_lattice

from mpsfem.fluid_mps.neighbours import NeighbourSearch
from mpsfem.fluid_mps.pressure_poisson import make_pressure_solver
from mpsfem.fluid_mps.source_filter import kernel_average_divergence

RE = 2.1  # the density radius, in l0


def _wendland_numpy(q):
    return np.where(q < 1.0, (1.0 - q) ** 4 * (1.0 + 4.0 * q), 0.0)


def _setup(dim, n=11):
    pos = square_lattice(dim, n, 1.0)
    kind = np.zeros(len(pos), np.int8)
    surface = np.zeros(len(pos), np.bool_)
    nb = NeighbourSearch(dim, RE).build(pos)
    inner = interior_mask(pos, [0] * dim, [n - 1] * dim, 3.0)
    return pos, kind, surface, nb, inner


@pytest.mark.parametrize("dim", [2, 3])
def test_a_linear_divergence_is_kept_and_a_checkerboard_is_damped(dim):
    """Interior lattice particles: a divergence linear in x is kept to round-off (the
    neighbourhood is symmetric); the checkerboard (-1)^(i+j(+k)) comes out as the numpy
    brute-force average, (1 + sum_j W_j s_j) / (1 + sum_j W_j) with s_j the neighbour's sign,
    and is at least halved."""
    pos, kind, surface, nb, inner = _setup(dim)
    out = np.empty(len(pos))
    linear = 0.3 + pos @ np.array([0.7, -1.1, 0.4][:dim])
    kernel_average_divergence(linear, pos, kind, surface, nb.indptr, nb.indices, RE, out)
    assert np.abs(out[inner] - linear[inner]).max() < 1e-12

    checker = (-1.0) ** np.rint(pos.sum(axis=1))
    kernel_average_divergence(checker, pos, kind, surface, nb.indptr, nb.indices, RE, out)
    i = np.flatnonzero(inner)[0]
    r = np.linalg.norm(pos - pos[i], axis=1)
    w = _wendland_numpy(r / RE)
    w[i] = 1.0
    expected = (w * checker).sum() / w.sum()
    assert out[i] == pytest.approx(expected, abs=1e-12)
    assert np.allclose(out[inner], out[i] * checker[inner] / checker[i], atol=1e-12)
    print(f"{dim}D: checkerboard amplitude after the filter {abs(expected):.3f}")
    assert abs(expected) < 0.5


def test_surface_neighbours_do_not_contribute_and_boundary_rows_keep_theirs():
    pos, kind, surface, nb, inner = _setup(2)
    div = np.ones(len(pos))
    i = np.flatnonzero(inner)[0]
    j = int(np.argmin(np.linalg.norm(pos - (pos[i] + [1.0, 0.0]), axis=1)))
    div[j] = 1e6
    surface[j] = True  # a surface particle's divergence is the truncated kernel's
    k = int(np.argmin(np.linalg.norm(pos - (pos[i] - [1.0, 0.0]), axis=1)))
    kind[k] = 1  # a WALL row keeps its own value
    div[k] = 7.0
    out = np.empty(len(pos))
    kernel_average_divergence(div, pos, kind, surface, nb.indptr, nb.indices, RE, out)
    assert out[i] == pytest.approx(1.0, abs=1e-12)
    assert out[k] == 7.0


def test_an_unknown_filter_or_one_with_the_higher_order_source_is_refused():
    kw = dict(dim=2, l0=1.0, re=4.01, re_density=2.1)
    with pytest.raises(ValueError, match="unknown source filter 'gauss'"):
        make_pressure_solver("direct", source_filter="gauss", **kw)
    with pytest.raises(ValueError, match="only with source_term = 'thesis_mixed'"):
        make_pressure_solver(
            "direct", source_filter="kernel_average", source_term="higher_order", **kw
        )


def test_the_scenario_refuses_the_filter_with_the_higher_order_source(request):
    from mpsfem.scenario.loader import load_scenario

    with pytest.raises(Exception, match="pressure.source_filter"):
        load_scenario(
            request.config.rootpath / "scenarios" / "hydrostatic_2d.toml",
            [
                'fluid.pressure.source_filter="kernel_average"',
                'fluid.pressure.source_term="higher_order"',
            ],
        )
