"""The impact potential-flow added-mass operator of a straight wetted patch
(structure_fem.added_mass_potential; issue 21, task H1): against the flat plate's closed forms
(Newman 1977, Marine Hydrodynamics, Table 4.2; the elliptic loading phi = a sqrt(c^2 - x^2)).

Tolerances from the discretisation's measured order: the rigid-heave total converges as
(panels)^-2 (cosine-spaced panels resolve the sqrt edge: 7.5e-2, 1.9e-2, 4.7e-3 relative at
4, 8, 16 panels on one element), phi at the panel points as (panels)^-1 in the max norm."""

import numpy as np
import pytest

from mpsfem.structure_fem.added_mass_potential import (
    patch_added_mass,
    patch_coordinates,
    patch_dipole,
)

RHO = 1000.0


def heave_error(elements: int, refine: int, length: float = 0.305) -> float:
    """Relative error of the rigid-heave added mass (sum of M_a) against rho pi l^2 / 8."""
    s = np.linspace(0.0, length, elements + 1)
    return patch_added_mass(s, RHO, refine).sum() / (RHO * np.pi * length**2 / 8.0) - 1.0


@pytest.mark.parametrize("elements", [1, 3, 10, 53])
def test_rigid_heave_is_the_flat_plates_one_face_added_mass(elements):
    """Sum of M_a = rho pi l^2 / 8 per m of depth (Newman 1977, Table 4.2: rho pi a^2 both
    faces, a = l / 2). Default refine 8: error <= 2e-2 / elements^2 (measured 1.9e-2 on one
    element, 2.1e-3 on three, 1.9e-4 on ten), always from below (Galerkin: the energy of the
    discrete sheet is below the exact one)."""
    err = heave_error(elements, 8)
    assert -2.0e-2 / elements**2 <= err < 0.0


def test_rigid_heave_converges_at_second_order():
    """Halving the panels cuts the heave error four times (observed order 2.0 +- 0.1)."""
    errs = [abs(heave_error(4, r)) for r in (4, 8, 16)]
    orders = np.log2(np.array(errs[:-1]) / np.array(errs[1:]))
    assert np.all(np.abs(orders - 2.0) < 0.1), orders


def test_light_plate_heave_limit():
    """docs/validation_bottom_slamming_light.md: the deep-water heave limit of the 0.305 m plate
    is rho pi L / 8 = 120 kg/m^2 per unit area (its finite-difference solver reached 154 at
    depth 0.114 m, the limit the shallow tank raises). The operator on the plate's 53 elements
    (H/20) per unit area: 119.8 kg/m^2 within 1e-3."""
    L = 0.305
    per_area = patch_added_mass(np.linspace(0.0, L, 54), RHO).sum() / L
    assert per_area == pytest.approx(RHO * np.pi * L / 8.0, rel=1e-3)
    assert per_area == pytest.approx(120.0, abs=0.5)


def test_uniform_acceleration_gives_the_elliptic_potential():
    """a_n = 1 on the whole patch: phi = sqrt(c^2 - x^2) (x from the centre, c = l / 2), max
    error relative to phi's peak below 1 / panels (measured about 0.12 / panels: 3.7e-3 at
    8 x 4 panels, 9.2e-4 at 32 x 4)."""
    L = 0.3
    s = np.linspace(0.0, L, 5)
    errs = []
    for refine in (8, 16, 32):
        x, phi = patch_dipole(s, np.ones(s.size), refine)
        exact = np.sqrt(np.maximum((L / 2) ** 2 - (x - L / 2) ** 2, 0.0))
        err = np.abs(phi - exact).max() / exact.max()
        assert err < 1.0 / (refine * 4)
        errs.append(err)
    order = np.log2(errs[0] / errs[2]) / 2.0
    assert order == pytest.approx(1.0, abs=0.1)


def test_symmetric_positive_definite_and_mode_dependent():
    """M_a symmetric (to round-off: it is (rho / 2) G^T H^-1 G), positive definite, and its
    Rayleigh quotient falls with the mode's wavenumber (about rho / k for short modes): the
    shape the lumped M_f cannot have."""
    L, n = 0.305, 40
    s = np.linspace(0.0, L, n + 1)
    M = patch_added_mass(s, RHO)
    assert np.abs(M - M.T).max() <= 1e-14 * np.abs(M).max()
    assert np.linalg.eigvalsh(M).min() > 0.0
    tributary = np.gradient(s)  # hat-function row sums (end nodes: half an element)
    tributary[[0, -1]] = 0.5 * (s[1] - s[0])
    quotients = []
    for j in (1, 4, 16):
        w = np.sin(j * np.pi * s / L)
        quotients.append(w @ M @ w / (w @ (tributary * w)))  # kg/m^2
    assert quotients[0] > quotients[1] > quotients[2]
    # short modes: rho / k within 25 % (k = j pi / L; the patch's ends and the mesh make it
    # differ from a periodic surface)
    for j, q in zip((4, 16), quotients[1:], strict=True):
        assert q == pytest.approx(RHO * L / (j * np.pi), rel=0.25)


def test_invariant_to_the_patch_orientation_and_position():
    """The operator depends only on the nodes' arc lengths: the same patch rotated and moved in
    the plane gives the same matrix (to the round-off of the arc lengths, 1e-16 m, amplified by
    the panel system's conditioning: measured 1e-12 relative, bound 1e-10); non-uniform nodes
    keep the heave total."""
    rng = np.random.default_rng(3)
    s = np.sort(np.r_[0.0, rng.uniform(0.0, 0.2, 7), 0.2])
    ref = patch_added_mass(s, RHO)
    for angle in (0.3, 2.0, -1.1):
        e = np.array([np.cos(angle), np.sin(angle)])
        pts = np.array([1.0, -2.0]) + s[:, None] * e
        M = patch_added_mass(patch_coordinates(pts), RHO)
        assert np.abs(M - ref).max() <= 1e-10 * np.abs(ref).max()
    assert ref.sum() == pytest.approx(RHO * np.pi * 0.2**2 / 8.0, rel=5e-3)


def test_bad_input_is_named():
    with pytest.raises(ValueError, match="density"):
        patch_added_mass(np.linspace(0.0, 1.0, 3), 0.0)
    with pytest.raises(ValueError, match="increasing"):
        patch_added_mass(np.array([0.0, 0.5, 0.4]), RHO)
    with pytest.raises(ValueError, match="not straight"):
        patch_coordinates(np.array([[0.0, 0.0], [0.5, 0.01], [1.0, 0.0]]))
