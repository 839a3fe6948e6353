"""fluid.pressure.structure_suction: negative pressure kept next to a structure member, away from
the free surface, and the clamp everywhere else (pressure_assembly.py, wall_boundary.py)."""

from __future__ import annotations

import numpy as np
import pytest

from mpsfem.fluid_mps.pressure_assembly import clamp_negative_except_at_structures
from mpsfem.fluid_mps.wall_boundary import wall_pressure
from mpsfem.scenario.base import ScenarioError
from mpsfem.scenario.fluid import FluidSection

RE = 0.021  # m: neighbours closer than this count
FLOOR = -5000.0  # Pa


def _pairs(pos):
    """All pairs (CSR), as a neighbour list longer than ``RE`` would hold them."""
    n = len(pos)
    indices = np.array([j for i in range(n) for j in range(n) if j != i], dtype=np.int32)
    indptr = np.arange(0, n * (n - 1) + 1, n - 1, dtype=np.int64)
    return indptr, indices


def test_only_deep_fluid_next_to_a_structure_keeps_its_suction():
    # 0 structure at the origin; 1 fluid beside it, deep (no surface particle near);
    # 2 fluid beside the structure but beside a surface particle (3) too; 4 fluid far from any
    # structure; 5 a wall particle; 6 a structure dummy beside fluid 7; 8 fluid just beyond RE
    pos = np.array(
        [
            [0, 0],
            [0.01, 0],
            [0, 0.02],
            [0, 0.035],
            [1, 1],
            [1, 0.99],
            [2, 0],
            [2.01, 0],
            [0.0215, 0],
        ],
        dtype=float,
    )
    kind = np.array([3, 0, 0, 0, 0, 1, 4, 0, 0], dtype=np.int8)
    surface = np.array([0, 0, 0, 1, 0, 0, 0, 0, 0], dtype=np.int8)
    p = np.array([-9000.0, -1000.0, -1000.0, -1000.0, -1000.0, -1000.0, 0.0, -20000.0, -1.0])
    indptr, indices = _pairs(pos)
    clamp_negative_except_at_structures(pos, p, kind, surface, indptr, indices, RE, FLOOR)
    assert p.tolist() == [FLOOR, -1000.0, 0.0, 0.0, 0.0, 0.0, 0.0, FLOOR, 0.0]


def test_positive_pressures_are_untouched():
    pos = np.array([[0.0, 0.0], [0.01, 0.0], [0.5, 0.5]])
    kind = np.array([3, 0, 0], dtype=np.int8)
    p = np.array([12.5, 3.25, 7.0])
    indptr, indices = _pairs(pos)
    out = clamp_negative_except_at_structures(
        pos, p.copy(), kind, np.zeros(3, np.int8), indptr, indices, RE, FLOOR
    )
    assert np.array_equal(out, p)


def test_the_structures_wall_pressure_may_turn_negative_down_to_the_floor():
    """A member's pressure rebuilt from a fluid neighbour in suction (no gravity, no wall
    acceleration: p_w = p_f) is that suction with the floor, 0 without it; a tank wall's stays
    at least 0 either way."""
    pos = np.array([[0.0, 0.0], [0.01, 0.0], [0.0, 0.01]])
    kind = np.array([0, 3, 1], dtype=np.int8)
    indptr, indices = _pairs(pos)
    args = (np.zeros(3, np.int8), indptr, indices, RE, 1, 1000.0, np.zeros(2), np.zeros((3, 2)), 1)
    for floor, member in ((0.0, 0.0), (FLOOR, -800.0), (-500.0, -500.0)):
        p = np.array([-800.0, 0.0, 0.0])
        wall_pressure(pos, p, kind, *args, floor)
        assert p[1] == pytest.approx(member, rel=1e-12, abs=1e-12) and p[2] == 0.0


def _fluid(**pressure) -> dict:
    return {
        "spacing": 0.01,
        "blocks": [{"lower": [0, 0], "upper": [0.1, 0.1]}],
        "walls": [{"shape": "tank", "name": "tank", "lower": [0, 0], "upper": [0.2, 0.2]}],
        "pressure": pressure,
    }


def test_a_positive_suction_floor_is_refused_naming_the_key():
    with pytest.raises((ScenarioError, ValueError), match="suction_floor"):
        FluidSection.model_validate(_fluid(structure_suction=True, suction_floor=10.0))
    spec = FluidSection.model_validate(_fluid(structure_suction=True))
    assert spec.pressure.suction_floor == pytest.approx(2339.0 - 101325.0)
