"""fluid.sph.wall_pressure = "wetted": a wall across an air gap is dry (delta_sph.dry_walls).

Adami et al.'s extrapolation (2012, eq. 27) gives a wall particle whose kernel reaches still
water across an air gap a negative pressure, p_w = p_f + rho g . (r_f - r_w) < 0, which pulls the
wall down and the free surface up. The "wetted" form zeroes the pressure of a wall particle whose
fluid lies 3/4 of a spacing or more beyond the wall face, and the fluid particle's own pressure in its
pairs with it, so the two exchange nothing; a wet wall keeps Adami's pressure, bit for bit.
"""

from __future__ import annotations

import numba
import numpy as np
import pytest

from mpsfem.fluid_sph import delta_sph
from mpsfem.fluid_sph.solver import DeltaSPHSolver
from mpsfem.scenario.fluid import FluidSection

L0 = 0.02
DEPTH = 0.2
RHO_G = 1000.0 * 9.81


def _lid(mode: str, gap: float, ratio: float = 1.3, integrator: str = "rk4",
         **extra) -> DeltaSPHSolver:  # fmt: skip
    """Still water 0.2 m deep in a 0.3 m tank, a rigid box ("lid", 3 l0 thick) held ``gap``
    spacings above the free surface over the middle 0.18 m, hydrostatic start."""
    y0 = DEPTH + gap * L0
    spec = FluidSection(
        method="delta-sph",
        spacing=L0,
        blocks=[{"lower": [0.0, 0.0], "upper": [0.3, DEPTH]}],
        walls=[
            {"shape": "tank", "lower": [0.0, 0.0], "upper": [0.3, 0.4], "name": "tank"},
            {"shape": "box", "lower": [0.06, y0], "upper": [0.24, y0 + 3 * L0], "name": "lid"},
        ],
        sph={"wall_pressure": mode, "smoothing_ratio": ratio, "integrator": integrator},
        boundary_force="momentum_exchange",
        **extra,
    )
    return DeltaSPHSolver(spec)


def _run(s: DeltaSPHSolver, t_end: float) -> None:
    while s.t < t_end - 1e-12:
        s.step(s.dt_towards(t_end))


@pytest.mark.parametrize("ratio", [1.3, 2.0])
@pytest.mark.parametrize("gap", [0.8, 1.2])
def test_a_wall_across_an_air_gap_is_dry(gap, ratio):
    """Gap 0.8 / 1.2 l0 between the lid's face and the free surface, inside the kernel's
    support (the first fluid row is 1.8 / 2.2 l0 from the lid's pressure layer; 2h = 2.6 / 4
    l0). Adami's form pulls: the lid's pressure layer is below -rho g l0 and its pair exchange
    is downward (checked, so the test can fail). The wetted form: every lid particle has p = 0
    and the pair exchange is exactly zero, at the start and after 0.05 s."""
    old = _lid("adami", gap, ratio)
    lid = old.patch("lid")
    nf = old.n_fluid
    assert old.p[lid.start : lid.stop].min() < -RHO_G * L0
    _run(old, 0.05)
    assert old.boundary_force(["lid"])[1] < -0.5  # N/m, downward

    new = _lid("wetted", gap, ratio)
    for _ in range(2):
        assert np.all(new.p[lid.start : lid.stop] == 0.0)
        assert np.all(new.wall_wet[lid.start - nf : lid.stop - nf] == 0.0)
        assert np.all(new.wall_exchange[new._patch_index["lid"]] == 0.0)
        _run(new, 0.05)


def test_wet_walls_keep_adamis_pressure_bit_for_bit():
    """Without a lid the tank's submerged walls are wholly wet: at the start every wall
    particle below the water line (one spacing of margin) has Adami's pressure bit for bit, and
    only the side walls' particles above the free surface change (to p >= Adami's, the pull
    removed)."""
    old = _lid("adami", 1.2)
    new = _lid("wetted", 1.2)
    tank = old.patch("tank")
    rows = np.arange(tank.start, tank.stop)
    below = old.pos[rows, 1] < DEPTH - L0
    assert below.sum() > 100
    assert np.array_equal(new.p[rows[below]], old.p[rows[below]])
    seen = rows[below & (old.p[rows] != 0.0)]  # with fluid in the support (deep dummies have none)
    assert np.all(new.wall_wet[seen - new.n_fluid] == 1.0)
    assert np.all(new.p[rows] >= old.p[rows] - 1e-9)


@pytest.mark.parametrize("integrator", ["rk4", "symplectic"])
def test_hydrostatic_wall_pressure_is_unchanged(integrator):
    """Still water 0.2 m deep with the lid 1.2 l0 above it, 0.1 s: the bottom wall's pressure
    layer and the bottom fluid row stay within 1 % of rho g (d - y) (as the tank test without a
    lid, tests/fluid_sph/test_delta_sph.py), and the wetted bottom-wall mean is within 0.5 % of
    Adami's (the two forms differ only at the side walls above the water and at the lid)."""
    means = {}
    for mode in ("adami", "wetted"):
        s = _lid(mode, 1.2, integrator=integrator)
        _run(s, 0.1)
        nf = s.n_fluid
        tank = s.patch("tank")
        rows = np.arange(tank.start, tank.stop)
        layer = rows[(s.kind[rows] == 1) & (s.pos[rows, 1] < 0.0)]  # the floor's pressure layer
        layer = layer[(s.pos[layer, 0] > 0.0) & (s.pos[layer, 0] < 0.3)]
        expected = RHO_G * (DEPTH - s.pos[layer, 1])
        means[mode] = s.p[layer].mean()
        assert means[mode] == pytest.approx(expected.mean(), rel=0.01)
        bottom = s.pos[:nf, 1] < L0
        exp_f = RHO_G * (DEPTH - s.pos[:nf, 1][bottom])
        assert s.p[:nf][bottom].mean() == pytest.approx(exp_f.mean(), rel=0.01)
    assert means["wetted"] == pytest.approx(means["adami"], rel=0.005)


@pytest.mark.parametrize("integrator", ["rk4", "symplectic"])
def test_budget_closes_with_partly_wet_walls(integrator):
    """Gap 0.5 l0: the lid's pressure layer is partly wet (0 < w < 1). Over 30 steps the
    tank's and the lid's reported pair exchanges are the budget's exchange and dP - G + J is
    round-off (< 1e-10 of the boundary impulse): the weighted pairs are still action =
    reaction."""
    s = _lid("wetted", 0.5, integrator=integrator, momentum_budget=True)
    lid = s.patch("lid")
    w = s.wall_wet[lid.start - s.n_fluid : lid.stop - s.n_fluid]
    assert np.any((w > 0.0) & (w < 1.0))
    s.budget.take(s.vel, s.kind)
    reported = np.zeros((2, 2))
    for _ in range(30):
        dt = s.dt_next
        s.step(dt)
        reported += dt * np.array([s.boundary_force([name]) for name in ("tank", "lid")])
    b = s.budget.take(s.vel, s.kind)
    scale = np.abs(b["tank/exchange"]).max()
    assert np.abs(b["lid/exchange"]).max() > 1e-6 * scale
    for k, name in enumerate(("tank", "lid")):
        assert np.abs(reported[k] - b[f"{name}/exchange"]).max() < 1e-10 * scale
    assert np.abs(b["residual_external"]).max() < 1e-10 * scale


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("ratio", [1.3, 2.0])
def test_half_space_support_is_half_a_normalised_kernel(dim, ratio):
    """The thresholds' lattice sums: the half-space from the particle's own row on and the one
    from the next row on make the whole lattice, whose Wendland C2 sum is 1 to the lattice's
    error (about 1 % at h = 1.3 l0); the sum falls with the distance and is 0 from 2h on."""
    whole = delta_sph.half_space_support(dim, ratio, 0.0) + delta_sph.half_space_support(
        dim, ratio, 1.0
    )
    assert whole == pytest.approx(1.0, abs=0.02)
    sums = [delta_sph.half_space_support(dim, ratio, d) for d in (1.0, 1.5, 2.0, 2.5)]
    assert all(a > b for a, b in zip(sums, sums[1:], strict=False) if a > 0.0)
    assert delta_sph.half_space_support(dim, ratio, 2.0 * ratio) == 0.0


@pytest.mark.parametrize("mode", ["adami", "wetted"])
def test_a_coupled_member_across_an_air_gap_is_dry(mode):
    """A horizontal structure member (one spacing thick, 0.2 m long) whose lower face is 1.2 l0
    above still water 0.2 m deep: its virtual particles (kinds STRUCTURE / STRUCTURE_DUMMY)
    reach the water. Adami's form pulls it down (the fluid's reaction on its particles < -0.2
    N/m); the wetted form gives every member particle p = 0 and a reaction of exactly zero."""
    from mpsfem.coupler.participant import InterfaceMesh
    from mpsfem.fluid_sph.participant import SPHParticipant

    n_el = 10
    y_mid = DEPTH + 1.2 * L0 + 0.5 * L0
    pts = np.c_[np.linspace(0.05, 0.25, n_el + 1), np.full(n_el + 1, y_mid)]
    mesh = InterfaceMesh(
        pts,
        np.tile([0.0, 1.0], (n_el + 1, 1)),
        {"line": np.c_[np.arange(n_el), np.arange(1, n_el + 1)]},
        L0,
    )
    fluid = FluidSection.model_validate(
        {
            "method": "delta-sph",
            "spacing": L0,
            "blocks": [{"lower": [0.0, 0.0], "upper": [0.3, DEPTH]}],
            "walls": [{"shape": "tank", "name": "tank", "lower": [0, 0], "upper": [0.3, 0.4]}],
            "sph": {"wall_pressure": mode},
        }
    )
    s = SPHParticipant(fluid, mesh, member_names=["lid"]).solver
    rows = s.ext_rows
    assert rows.size > 0
    if mode == "adami":
        assert s.p[rows].min() < -RHO_G * L0
        assert s.reaction[:, 1].sum() < -0.2
    else:
        assert np.all(s.p[rows] == 0.0)
        assert np.all(s.reaction == 0.0)


@pytest.mark.skipif(numba.config.NUMBA_NUM_THREADS < 2, reason="needs 2 numba threads")
def test_wetted_walls_do_not_depend_on_the_thread_count():
    """dry_walls' three parallel passes each write their own rows: with the lid partly wet
    (gap 0.5 l0), 1 and 2 threads give the same bits over 5 steps."""
    states = []
    for threads in (1, 2):
        numba.set_num_threads(threads)
        try:
            s = _lid("wetted", 0.5)
            for _ in range(5):
                s.step(s.dt_next)
        finally:
            numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
        states.append({k: v.copy() for k, v in s.state().items()} | {"wet": s.wall_wet.copy()})
    for k, v in states[0].items():
        assert np.array_equal(v, states[1][k]), k


@pytest.mark.parametrize("load", ["normal_pairs", "exchange"])
def test_a_partly_wet_member_receives_what_the_fluid_loses(load):
    """The horizontal member with its lower face 0.5 l0 above still water (partly wet: some
    member particles 0 < w < 1), wetted walls, one right-hand side 10 steps in: the fluid's rate
    of momentum is its weight less the tank's and the member's weighted reactions, to round-off
    (1e-10 of the member's force), with the projected pairs and with the whole exchange."""
    from mpsfem.coupler.participant import InterfaceMesh
    from mpsfem.fluid_sph.participant import SPHParticipant

    n_el = 10
    y_mid = DEPTH + 0.5 * L0 + 0.5 * L0
    pts = np.c_[np.linspace(0.05, 0.25, n_el + 1), np.full(n_el + 1, y_mid)]
    mesh = InterfaceMesh(
        pts,
        np.tile([0.0, 1.0], (n_el + 1, 1)),
        {"line": np.c_[np.arange(n_el), np.arange(1, n_el + 1)]},
        L0,
    )
    fluid = FluidSection.model_validate(
        {
            "method": "delta-sph",
            "spacing": L0,
            "blocks": [{"lower": [0.0, 0.0], "upper": [0.3, DEPTH]}],
            "walls": [{"shape": "tank", "name": "tank", "lower": [0, 0], "upper": [0.3, 0.4]}],
            "sph": {"wall_pressure": "wetted", "structure_load": load},
        }
    )
    fl = SPHParticipant(fluid, mesh, member_names=["lid"])
    for _ in range(10):
        fl.advance(fl.max_dt())
    s = fl.solver
    s.rhs()
    nf = s.n_fluid
    w = s.wall_wet[s.ext_rows - nf]
    assert np.any((w > 0.0) & (w < 1.0))
    nb = s._last_neighbours
    slot = np.full(s.n, -1, dtype=np.int64)
    slot[nf:] = np.arange(s.n - nf)
    slot[s.ext_rows] = -1
    tank = np.zeros((s.n - nf, s.dim))
    delta_sph.wall_reaction(s.pos, s.rho, s.vol, s.p, nb.indptr, nb.indices, nf, s.inv_h,
                            s.grad_coef, s.corrected, s.M, slot, tank, s.wall_wet)  # fmt: skip
    rate = s.mass * s.acc[:nf].sum(axis=0)
    member = s.reaction.sum(axis=0)
    lost = nf * s.mass * s.gravity - tank.sum(axis=0) - member
    size = np.abs(member).max()
    assert size > 1e-3  # N/m: the partly wet member is loaded
    assert np.abs(rate - lost).max() < 1e-10 * size
