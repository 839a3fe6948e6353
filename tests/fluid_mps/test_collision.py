import numba
import numpy as np
import pytest

from mpsfem.fluid_mps.collision import collide
from mpsfem.fluid_mps.neighbours import build_neighbours
from mpsfem.fluid_mps.particle_kinds import FLUID, WALL

L0 = 0.01


def run(pos, vel, kind, distance=0.5 * L0, e=0.2):
    nb = build_neighbours(pos, 2.1 * L0)
    vel = vel.copy()
    collide(pos, vel, kind, nb.indptr, nb.indices, distance, e)
    return vel


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("e", [0.0, 0.2, 1.0])
def test_pair_conserves_momentum_and_applies_restitution(dim, e):
    rng = np.random.default_rng(dim)
    pos = np.zeros((2, dim))
    pos[1] = rng.normal(size=dim)
    pos[1] *= 0.4 * L0 / np.linalg.norm(pos[1])
    normal = pos[1] / np.linalg.norm(pos[1])
    vel = rng.normal(size=(2, dim))
    vel[0] += 2.0 * normal  # approaching
    vel[1] -= 2.0 * normal
    kind = np.zeros(2, np.int8)
    a_before = (vel[0] - vel[1]) @ normal
    assert a_before > 0
    out = run(pos, vel, kind, e=e)
    np.testing.assert_allclose(out.sum(axis=0), vel.sum(axis=0), rtol=0, atol=1e-14)
    a_after = (out[0] - out[1]) @ normal
    assert a_after == pytest.approx(-e * a_before, rel=1e-12)
    tangential = lambda v: v - np.outer(v @ normal, normal)  # noqa: E731
    np.testing.assert_allclose(tangential(out), tangential(vel), atol=1e-14)


def test_separating_or_distant_pairs_unchanged():
    pos = np.array([[0.0, 0.0], [0.3 * L0, 0.0], [5 * L0, 0.0], [5.6 * L0, 0.0]])
    vel = np.array([[-1.0, 0.0], [1.0, 0.0], [1.0, 0.0], [-1.0, 0.0]])  # 0-1 separate, 2-3 far
    out = run(pos, vel, np.zeros(4, np.int8))
    np.testing.assert_array_equal(out, vel)


def test_wall_reflects_fluid_and_stays_put():
    pos = np.array([[0.0, 0.0], [0.0, -0.3 * L0]])
    vel = np.array([[0.5, -2.0], [0.0, 0.0]])
    kind = np.array([FLUID, WALL], np.int8)
    out = run(pos, vel, kind, e=0.2)
    np.testing.assert_allclose(out[0], [0.5, 0.4], rtol=1e-12)  # normal -2 -> +0.4
    np.testing.assert_array_equal(out[1], vel[1])


def test_many_particles_momentum_and_thread_independence():
    rng = np.random.default_rng(7)
    pos = rng.uniform(0, 20 * L0, size=(800, 2))
    vel = rng.normal(size=(800, 2))
    kind = np.zeros(800, np.int8)
    res = []
    saved = numba.get_num_threads()
    try:
        for t in sorted({1, saved}):
            numba.set_num_threads(t)
            res.append(run(pos, vel, kind, distance=0.8 * L0))
    finally:
        numba.set_num_threads(saved)
    assert np.any(res[0] != vel)
    np.testing.assert_allclose(res[0].sum(axis=0), vel.sum(axis=0), atol=1e-11)
    for r in res[1:]:
        np.testing.assert_array_equal(r, res[0])


def test_bad_parameters():
    pos = np.zeros((1, 2))
    with pytest.raises(ValueError, match="restitution"):
        collide(
            pos,
            pos.copy(),
            np.zeros(1, np.int8),
            np.zeros(2, np.int64),
            np.zeros(0, np.int32),
            0.5,
            1.5,
        )


def _wall_impulse(r, ramp, distance=0.5 * L0, e=0.2, speed=2.0):
    """Velocity change of a fluid particle approaching a wall particle at distance r (m)."""
    pos = np.array([[0.0, 0.0], [r, 0.0]])
    vel = np.array([[speed, 0.0], [0.0, 0.0]])
    kind = np.array([FLUID, WALL], np.int8)
    nb = build_neighbours(pos, 2.1 * L0)
    out = vel.copy()
    collide(pos, out, kind, nb.indptr, nb.indices, distance, e, ramp=ramp)
    return out[0, 0] - speed


def test_ramp_zero_is_the_hard_threshold():
    """ramp = 0 (the default) keeps the hard threshold: the full impulse -(1 + e) a just
    inside the distance, none at or beyond it."""
    d = 0.5 * L0
    assert _wall_impulse(d * (1 - 1e-9), 0.0) == pytest.approx(-1.2 * 2.0, rel=1e-15)
    assert _wall_impulse(d * (1 + 1e-9), 0.0) == 0.0


@pytest.mark.parametrize("ramp", [0.1, 0.5])
def test_ramp_makes_the_impulse_continuous_in_distance(ramp):
    """With a ramp the impulse is full below (1 - ramp) d, falls linearly to zero at d
    (collision.ramp_weight), and so changes by at most (1 + e) a / (ramp d) per metre: a
    displacement of 1e-7 m moves it by a bounded amount instead of the whole impulse."""
    d = 0.5 * L0
    full = -1.2 * 2.0
    assert _wall_impulse(0.5 * (1 - ramp) * d, ramp) == pytest.approx(full, rel=1e-15)
    assert _wall_impulse((1 - ramp) * d, ramp) == pytest.approx(full, rel=1e-12)
    for share in (0.25, 0.5, 0.75):
        r = (1 - ramp * share) * d  # share of the way from d back to the ramp's inner end
        assert _wall_impulse(r, ramp) == pytest.approx(share * full, rel=1e-9)
    assert abs(_wall_impulse(d * (1 - 1e-9), ramp)) < 1e-7
    slope = abs(full) / (ramp * d)
    rs = np.linspace(0.3 * d, 0.999 * d, 200)
    dv = np.array([_wall_impulse(r, ramp) for r in rs])
    assert np.max(np.abs(np.diff(dv)) / np.diff(rs)) <= slope * (1 + 1e-9)


@pytest.mark.parametrize("ramp", [0.0, 0.3])
def test_ramp_keeps_pairs_conserving_momentum(ramp):
    """A ramp scales both particles' changes of a fluid pair alike: momentum is kept, and
    the relative normal velocity becomes -(e w + w - 1) a with w the ramp's share."""
    rng = np.random.default_rng(11)
    pos = rng.uniform(0, 20 * L0, size=(800, 2))
    vel = rng.normal(size=(800, 2))
    kind = np.zeros(800, np.int8)
    nb = build_neighbours(pos, 2.1 * L0)
    out = vel.copy()
    collide(pos, out, kind, nb.indptr, nb.indices, 0.8 * L0, 0.2, ramp=ramp)
    assert np.any(out != vel)
    np.testing.assert_allclose(out.sum(axis=0), vel.sum(axis=0), atol=1e-11)
    # one pair at 0.95 of the distance: w = 0.05 / ramp (1 without a ramp)
    pair = np.array([[0.0, 0.0], [0.95 * 0.8 * L0, 0.0]])
    v = np.array([[1.0, 0.0], [-1.0, 0.0]])  # approaching at a = 2 m/s
    nb = build_neighbours(pair, 2.1 * L0)
    after = v.copy()
    collide(pair, after, np.zeros(2, np.int8), nb.indptr, nb.indices, 0.8 * L0, 0.2, ramp=ramp)
    w = 0.05 / ramp if ramp > 0.0 else 1.0
    rel = after[0, 0] - after[1, 0]
    assert rel == pytest.approx(-(0.2 * w + w - 1.0) * 2.0, rel=1e-12)


def test_bad_ramp():
    pos = np.zeros((1, 2))
    with pytest.raises(ValueError, match="ramp"):
        collide(pos, pos.copy(), np.zeros(1, np.int8), np.zeros(2, np.int64),
                np.zeros(0, np.int32), 0.5, 0.2, ramp=1.0)  # fmt: skip
