import numpy as np
import pytest

from mpsfem.fluid_mps.kernels import IMPROVED, ORIGINAL, weight, weight_code, weight_py
from mpsfem.fluid_mps.lattice import (
    lattice_constants,
    lattice_offsets,
    uniaxial_density_response,
)


def test_improved_and_original_values():
    re = 2.1
    r = np.array([0.0, 0.5, 1.0, 2.0, 2.1, 3.0])
    w_imp = weight_py(r, re, "improved")
    np.testing.assert_allclose(w_imp[:4], re / (0.85 * r[:4] + 0.15 * re) - 1.0, rtol=1e-15)
    assert w_imp[0] == pytest.approx(1 / 0.15 - 1)
    assert w_imp[4] == 0.0 and w_imp[5] == 0.0
    w_org = weight_py(r[1:], re, "original")
    np.testing.assert_allclose(w_org[:3], re / r[1:4] - 1.0, rtol=1e-15)
    assert w_org[3] == 0.0 and w_org[4] == 0.0
    assert np.isfinite(weight_py(0.0, re, "original"))
    # njit version agrees with the NumPy one
    for code, name in ((IMPROVED, "improved"), (ORIGINAL, "original")):
        for x in r[1:]:
            assert weight(x, re, code) == pytest.approx(float(weight_py(x, re, name)), rel=1e-15)


def test_weight_registry_errors():
    assert weight_code("improved") == IMPROVED
    assert weight_code("original") == ORIGINAL
    assert weight_code(1) == ORIGINAL
    with pytest.raises(ValueError, match="unknown weight function 'gauss'.*improved, original"):
        weight_code("gauss")
    with pytest.raises(ValueError):
        weight_code(7)


def test_lattice_constants_2d_original_known_value():
    # Koshizuka's kernel, re = 2.1 l0: 4 (2.1 - 1) + 4 (2.1/sqrt2 - 1) + 4 (2.1/2 - 1) = 6.5397
    n0, lam = lattice_constants(2, 1.0, 2.1, "original")
    expect = 4 * (2.1 - 1) + 4 * (2.1 / np.sqrt(2) - 1) + 4 * (2.1 / 2 - 1)
    assert n0 == pytest.approx(expect, rel=1e-14)
    lam_expect = (4 * 1.1 * 1 + 4 * (2.1 / np.sqrt(2) - 1) * 2 + 4 * 0.05 * 4) / expect
    assert lam == pytest.approx(lam_expect, rel=1e-14)


@pytest.mark.parametrize("dim,re,count", [(2, 2.1, 12), (2, 4.01, 48), (3, 2.1, 32)])
def test_lattice_offsets_and_scaling(dim, re, count):
    assert lattice_offsets(dim, 1.0, re).shape == (count, dim)
    n0a, la = lattice_constants(dim, 1.0, re)
    n0b, lb = lattice_constants(dim, 0.002, re * 0.002)
    assert n0a == pytest.approx(n0b, rel=1e-12)  # n0 is scale free
    assert lb == pytest.approx(la * 0.002**2, rel=1e-12)  # lambda scales with l0^2


def test_lattice_bad_input():
    with pytest.raises(ValueError, match="dim must be 2 or 3"):
        lattice_constants(1, 1.0, 2.1)
    with pytest.raises(ValueError, match="unknown weight"):
        lattice_constants(2, 1.0, 2.1, "cubic")


def test_uniaxial_density_response_2d_original_known_value():
    # w = re/r - 1, w' = -re/r^2; compressed by eps along y, r_j shrinks by eps y_j^2 / r_j:
    # dn/deps = sum_j re y_j^2 / r_j^3 = 2 (2.1) + 4 (2.1) / (2 sqrt2) + 2 (2.1) 4 / 8
    n0, _ = lattice_constants(2, 1.0, 2.1, "original")
    expect = (2 * 2.1 + 4 * 2.1 / (2 * np.sqrt(2)) + 2 * 2.1 * 4 / 8) / n0
    assert uniaxial_density_response(2, 1.0, 2.1, "original") == pytest.approx(expect, rel=1e-8)
    # scale free, and the kernel sum over-reads a continuum's strain in 2D (s > 1)
    s = uniaxial_density_response(2, 0.004, 2.1 * 0.004, "improved")
    assert s == pytest.approx(uniaxial_density_response(2, 1.0, 2.1, "improved"), rel=1e-8)
    assert 1.3 < s < 1.4
