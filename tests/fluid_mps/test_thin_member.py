"""Nothing interacts through a structure member thinner than the kernel radius.

1. The filtered neighbour list against a brute-force geometric reference: no fluid pair whose
   segment crosses the member's mid-line survives, every other fluid pair does, and fluid sees
   only the layers of its own face.
2. Still water on both sides of a member one spacing thick (the density radius 2.1 l0 and the
   pressure radius 4.01 l0 both reach across it): each side keeps its own hydrostatic pressure
   rho g (H_side - y), for a vertical partition with different levels on its two sides and for a
   horizontal plate with water above and below; the load on the partition is the hydrostatic
   resultant rho g (H1^2 - H2^2) / 2. Without the filter the same scenes fail.
"""

from __future__ import annotations

import numpy as np
import pytest

from mpsfem.coupler.participant import InterfaceMesh
from mpsfem.fluid_mps.neighbours import NeighbourSearch
from mpsfem.fluid_mps.participant import FluidParticipant
from mpsfem.fluid_mps.particle_kinds import FLUID
from mpsfem.fluid_mps.solver import FluidRunError
from mpsfem.scenario.fluid import FluidSection

L0 = 0.01
RHO, G = 1000.0, 9.81
STEPS, DT = 20, 1e-3
#: pressure tolerance near the member: the hydrostatic increment across half a spacing (a wall
#: face is resolved to +-l0 / 2)
P_TOL = 0.5 * RHO * G * L0


def member(start, end, n_el, thickness) -> InterfaceMesh:
    start, end = np.asarray(start, float), np.asarray(end, float)
    pts = start + np.linspace(0.0, 1.0, n_el + 1)[:, None] * (end - start)
    t = (end - start) / np.linalg.norm(end - start)
    nrm = np.tile([-t[1], t[0]], (n_el + 1, 1))
    return InterfaceMesh(
        pts, nrm, {"line": np.c_[np.arange(n_el), np.arange(1, n_el + 1)]}, thickness
    )


def fluid_section(blocks, upper) -> FluidSection:
    return FluidSection.model_validate(
        {
            "spacing": L0,
            "blocks": [{"lower": lo, "upper": hi} for lo, hi in blocks],
            "walls": [{"shape": "tank", "name": "tank", "lower": [0, 0], "upper": upper}],
        }
    )


def _cross(a, b, p, q) -> bool:
    o = lambda u, v, w: (v[0] - u[0]) * (w[1] - u[1]) - (v[1] - u[1]) * (w[0] - u[0])  # noqa: E731
    return o(p, q, a) * o(p, q, b) < 0 and o(a, b, p) * o(a, b, q) < 0


@pytest.mark.parametrize("tilt", [0.0, 0.3])
def test_filter_against_brute_force(tilt):
    """A tilted member of thickness 0.6 l0, its tip in the open, in a cloud of fluid particles
    on both sides and beyond the tip."""
    c, L, T = np.array([0.2, 0.1]), 0.1, 0.6 * L0
    t = np.array([np.sin(tilt), np.cos(tilt)])
    n = np.array([-t[1], t[0]])
    mesh = member(c, c + L * t, 8, T)
    fluid = fluid_section([([0.1, 0.05], [0.3, 0.25])], [0.41, 0.4])
    fp = FluidParticipant(fluid, mesh, member_names=["m"])
    s = fp.solver
    rng = np.random.default_rng(7)
    f = np.flatnonzero(s.kind == FLUID)
    s.pos[f] += rng.uniform(-0.3 * L0, 0.3 * L0, size=(f.size, 2))  # off the lattice
    raw = NeighbourSearch(2, s.search_radius).build(s.pos)
    rows_raw = [set(raw.indices[raw.indptr[i] : raw.indptr[i + 1]].tolist()) for i in range(s.n)]
    nb = fp.filter(raw, s.pos, s.kind)
    rows = [nb.indices[nb.indptr[i] : nb.indptr[i + 1]] for i in range(s.n)]
    assert all(np.all(np.diff(r) > 0) for r in rows)  # ascending, no duplicates
    kept = [set(r.tolist()) for r in rows]
    assert all(k <= r for k, r in zip(kept, rows_raw, strict=True))
    assert fp.filter.dropped == sum(len(r) for r in rows_raw) - sum(len(k) for k in kept) > 0
    member_of, side_of = fp.surface.member_of, fp.surface.side_of
    along = (s.pos - c) @ t
    eta = (s.pos - c) @ n
    beside = (along >= 0) & (along <= L)
    a, b = c, c + L * t
    checked = {"fluid-fluid": 0, "beside": 0, "beyond": 0, "member": 0}
    for i in range(s.n):
        for j in rows_raw[i]:
            ki, kj = s.kind[i], s.kind[j]
            if ki == FLUID and kj == FLUID:  # rule 3: exactly the pairs that cross the mid-line
                assert (j in kept[i]) == (not _cross(s.pos[i], s.pos[j], a, b)), (i, j)
                checked["fluid-fluid"] += 1
            elif ki == FLUID and member_of[j] == 0:
                if beside[i]:  # rule 2: fluid beside the member sees its own face's layers only
                    assert (j in kept[i]) == (np.sign(eta[i]) == side_of[j]), (i, j)
                    assert (i in kept[j]) == (j in kept[i])
                    checked["beside"] += 1
                else:  # beyond the tip: the member's rows keep all such fluid
                    assert i in kept[j]
                    checked["beyond"] += 1
            elif member_of[i] == 0 and member_of[j] == 0:  # rule 1
                assert (j in kept[i]) == (side_of[i] == side_of[j])
                checked["member"] += 1
            elif member_of[i] < 0 and member_of[j] < 0 or ki != FLUID and kj != FLUID:
                assert j in kept[i]  # rigid walls are never filtered
    assert min(checked.values()) > 0, checked
    # beyond the tip a fluid particle sees each body position once and nothing virtual, and the
    # tip is not invisible: fluid within a spacing of it sees part of it (the member is thinner
    # than l0, so no row lies on a side's own half: body_half's mid-line rows)
    tip = c + L * t
    for i in f[~beside[f]]:
        seen = [j for j in kept[i] if member_of[j] == 0]
        body = np.abs((s.pos[seen] - c) @ n) <= max(0.5 * T, 0.5 * L0) + 1e-9
        assert body.all()
        if np.linalg.norm(s.pos[i] - tip) < L0:
            assert seen, i
        key = np.round(s.pos[seen] / (1e-6 * L0)).astype(np.int64)
        assert len({tuple(k) for k in key}) == len(seen)


def run(fluid, mesh, use_filter=True):
    fp = FluidParticipant(fluid, mesh, member_names=["m"])
    if not use_filter:
        fp.solver.neighbour_filter = None
    for _ in range(STEPS):
        fp.advance(min(fp.max_dt(), DT))
    return fp


def near_error(fp, mask, level):
    """rms of p - rho g (level - y) over the fluid particles in ``mask`` (Pa)."""
    s = fp.solver
    err = s.p[mask] - RHO * G * (level - s.pos[mask, 1])
    return float(np.sqrt(np.mean(err**2)))


def partition_scene():
    fluid = fluid_section([([0, 0], [0.2, 0.2]), ([0.2, 0], [0.41, 0.1])], [0.41, 0.4])
    return fluid, member([0.205, 0.0], [0.205, 0.3], 10, L0)  # faces x = 0.2 and 0.21


def shelf_scene():
    fluid = fluid_section([([0, 0], [0.41, 0.3])], [0.41, 0.5])
    return fluid, member([0.0, 0.155], [0.3, 0.155], 10, L0)  # faces y = 0.15 and 0.16


def test_partition_keeps_two_hydrostatic_levels():
    fp = run(*partition_scene())
    s = fp.solver
    f = (s.kind == FLUID) & (np.abs(s.pos[:, 0] - 0.205) < 0.04)
    left = f & (s.pos[:, 0] < 0.205) & (s.pos[:, 1] < 0.2 - 3 * L0)
    right = f & (s.pos[:, 0] > 0.205) & (s.pos[:, 1] < 0.1 - 3 * L0)
    e_left, e_right = near_error(fp, left, 0.2), near_error(fp, right, 0.1)
    force = fp.member_force("m")[0]
    exact = 0.5 * RHO * G * (0.2**2 - 0.1**2)
    print(
        f"partition after {STEPS} steps: rms p error left {e_left:.1f} Pa, right {e_right:.1f} Pa "
        f"(tolerance {P_TOL:.1f}); force {force:.2f} vs {exact:.2f} N/m"
    )
    assert e_left < P_TOL and e_right < P_TOL
    assert force == pytest.approx(exact, rel=0.02)


def test_shelf_keeps_water_above_and_below_hydrostatic():
    fp = run(*shelf_scene())
    s = fp.solver
    f = (s.kind == FLUID) & (s.pos[:, 0] < 0.3 - 3 * L0)
    above = f & (s.pos[:, 1] > 0.16) & (s.pos[:, 1] < 0.2)
    below = f & (s.pos[:, 1] < 0.15) & (s.pos[:, 1] > 0.11)
    e_above, e_below = near_error(fp, above, 0.3), near_error(fp, below, 0.3)
    print(f"shelf: rms p error above {e_above:.1f} Pa, below {e_below:.1f} Pa")
    assert e_above < P_TOL and e_below < P_TOL
    # the plate carries only the water column's pressure difference across its thickness
    fy = fp.member_force("m")[1]
    print(f"shelf: net vertical force {fy:.2f} N/m (rho g T x 0.3 m = {RHO * G * L0 * 0.3:.2f})")
    assert abs(fy) < 2.0 * RHO * G * L0 * 0.3


@pytest.mark.parametrize("scene", [partition_scene, shelf_scene])
def test_without_the_filter_the_scenes_fail(scene):
    """The reference for the two tests above: the same scenes with the filter switched off."""
    fluid, mesh = scene()
    try:
        fp = run(fluid, mesh, use_filter=False)
    except FluidRunError:
        return  # blew up: fluid interacted through the member
    s = fp.solver
    f = s.kind == FLUID
    err = near_error(fp, f & (s.pos[:, 1] < 0.08), 0.2 if scene is partition_scene else 0.3)
    assert err > P_TOL


@pytest.mark.parametrize("angle", [np.pi / 3, 75 * np.pi / 180, np.pi / 2])
def test_filter_follows_a_member_turned_far(angle):
    """The member of the brute-force scene and its fluid cloud turned rigidly by 60-90 degrees
    about the member's root (the member through the structure surface's large-rotation
    placement, the fluid by hand): the filter keeps exactly the pairs it keeps in the upright
    scene (pairs with the tank walls, which do not turn, aside), so the two faces' fluid stay
    apart; and its crossing rule still holds in the turned scene."""
    c, L, T = np.array([0.2, 0.1]), 0.1, 0.6 * L0
    mesh = member(c, c + L * np.array([0.0, 1.0]), 8, T)
    fluid = fluid_section([([0.1, 0.05], [0.3, 0.25])], [0.41, 0.4])
    fp = FluidParticipant(fluid, mesh, member_names=["m"])
    s = fp.solver
    rng = np.random.default_rng(11)
    f = np.flatnonzero(s.kind == FLUID)
    s.pos[f] += rng.uniform(-0.3 * L0, 0.3 * L0, size=(f.size, 2))
    turned = (s.kind == FLUID) | (fp.surface.member_of >= 0)

    def kept_pairs():
        raw = NeighbourSearch(2, s.search_radius).build(s.pos)
        nb = fp.filter(raw, s.pos, s.kind)
        out = set()
        for i in np.flatnonzero(turned):
            for j in nb.indices[nb.indptr[i] : nb.indptr[i + 1]]:
                if turned[j]:
                    out.add((int(i), int(j)))
        return out

    upright = kept_pairs()
    cs, sn = np.cos(angle), np.sin(angle)
    rot = lambda x: c + (x - c) @ np.array([[cs, sn], [-sn, cs]])  # noqa: E731
    ref_if = fp.interface().points
    fp.surface.place(s, rot(ref_if) - ref_if, 0.0 * ref_if)
    s.pos[f] = rot(s.pos[f])
    assert np.abs(s.pos[fp.surface.index] - rot(fp.surface.ref)).max() < 1e-12
    after = kept_pairs()
    assert after == upright
    # the crossing rule directly: no kept fluid pair crosses the turned mid-line
    a, b = rot(c[None])[0], rot((c + L * np.array([0.0, 1.0]))[None])[0]
    fluid_pairs = [(i, j) for i, j in after if s.kind[i] == FLUID and s.kind[j] == FLUID]
    assert fluid_pairs and not any(_cross(s.pos[i], s.pos[j], a, b) for i, j in fluid_pairs)
