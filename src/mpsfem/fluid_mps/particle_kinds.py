"""Particle kind codes (int8), shared with the results file contract (design brief).

- FLUID (0): fluid particle.
- WALL (1): first wall layer; carries pressure (an unknown of the pressure Poisson equation).
- DUMMY (2): dummy wall layers behind WALL; counted in the particle number density only, pressure
  always 0, never an unknown of the pressure equation.
- STRUCTURE (3): structure surface; carries pressure like WALL (the coupling load is read from it).
- STRUCTURE_DUMMY (4): dummy layers of a structure, like DUMMY.

"Pressure-carrying boundary" means WALL or STRUCTURE. The helpers are numba ``njit`` functions,
usable from Python and from other kernels alike.
"""

from __future__ import annotations

import numpy as np
from numba import njit

FLUID = np.int8(0)
WALL = np.int8(1)
DUMMY = np.int8(2)
STRUCTURE = np.int8(3)
STRUCTURE_DUMMY = np.int8(4)

KIND_NAMES: dict[int, str] = {
    0: "fluid",
    1: "wall",
    2: "dummy",
    3: "structure",
    4: "structure_dummy",
}


@njit(cache=True, inline="always")
def is_fluid(k):
    return k == 0


@njit(cache=True, inline="always")
def is_pressure_wall(k):
    """WALL or STRUCTURE: a boundary particle that carries pressure."""
    return k == 1 or k == 3


@njit(cache=True, inline="always")
def is_dummy(k):
    """DUMMY or STRUCTURE_DUMMY: number density only, pressure always 0."""
    return k == 2 or k == 4


@njit(cache=True, inline="always")
def carries_pressure(k):
    """FLUID, WALL or STRUCTURE: may be an unknown of the pressure equation."""
    return k == 0 or k == 1 or k == 3


@njit(cache=True, inline="always")
def is_boundary(k):
    """Any wall or structure particle (not fluid)."""
    return k != 0


def dummy_mask(kind: np.ndarray) -> np.ndarray:
    """Boolean mask of an int8 kind array: True for DUMMY and STRUCTURE_DUMMY (:func:`is_dummy`
    on a whole array, outside numba)."""
    return (kind == DUMMY) | (kind == STRUCTURE_DUMMY)


def pressure_wall_mask(kind: np.ndarray) -> np.ndarray:
    """Boolean mask of an int8 kind array: True for WALL and STRUCTURE
    (:func:`is_pressure_wall` on a whole array, outside numba)."""
    return (kind == WALL) | (kind == STRUCTURE)
