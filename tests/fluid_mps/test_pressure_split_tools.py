"""validation/mps_pressure_split.py's consistent divergence (the diagnostic that tells particle
noise from an operator's error on a smooth flow): exact for a linear velocity field on a
disordered lattice, where MPS's own divergence (eq. 2-15) is not."""

import sys
from pathlib import Path

import numpy as np
from scipy.spatial import cKDTree

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "scenarios"))
from validation_script import load  # noqa: E402

from mpsfem.fluid_mps import operators  # noqa: E402
from mpsfem.fluid_mps.kernels import weight, weight_code  # noqa: E402


def test_consistent_divergence_is_exact_for_a_linear_field():
    split = load("mps_pressure_split")
    rng = np.random.default_rng(0)
    l0, re = 0.01, 0.021
    grid = np.stack(np.meshgrid(np.arange(20), np.arange(20)), -1).reshape(-1, 2) * l0
    pos = grid + rng.normal(0.0, 0.1 * l0, grid.shape)
    grad_u = np.array([[1.3, -0.4], [0.7, -0.2]])  # 1/s; trace 1.1
    vel = pos @ grad_u.T

    class Pairs:
        pass

    lists = cKDTree(pos).query_ball_point(pos, re)
    nb = Pairs()
    nb.indptr = np.r_[0, np.cumsum([len(x) for x in lists])].astype(np.int64)
    nb.indices = np.concatenate(lists).astype(np.int32)
    interior = np.array([i for i in range(len(pos)) if np.all(np.abs(pos[i] / l0 - 9.5) < 6)])
    wcode = weight_code("improved")
    exact = split.corrected_divergence(pos, vel, interior, nb, re, wcode)
    np.testing.assert_allclose(exact, np.trace(grad_u), rtol=1e-12)
    n0 = float(np.mean([sum(weight(np.linalg.norm(pos[j] - pos[i]), re, wcode)
                            for j in lists[i] if j != i) for i in interior]))  # fmt: skip
    plain = np.empty(len(pos))
    operators.divergence(pos, vel, np.zeros(len(pos), np.int8), nb.indptr, nb.indices, re, wcode,
                         n0, plain)  # fmt: skip
    assert np.abs(plain[interior] - np.trace(grad_u)).max() > 1e-3  # MPS's is not exact here
