"""The reference values of validation/wedge_entry.py: the modified Logvinovich model's closed
forms against a direct quadrature of its pressure, its small-deadrise limit (Wagner), and the
convergence summary's Richardson estimate on sequences with a known limit."""

from __future__ import annotations

import importlib.util
import math
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import quad
from scipy.optimize import brentq


def _study():
    path = Path(__file__).resolve().parents[2] / "validation" / "wedge_entry.py"
    spec = importlib.util.spec_from_file_location("wedge_entry_refs", path)
    module = importlib.util.module_from_spec(spec)
    sys.modules["wedge_entry_refs"] = module
    spec.loader.exec_module(module)
    return module


@pytest.mark.parametrize("beta_deg", [5, 10, 20, 30, 40])
def test_mlm_force_closed_form_matches_quadrature(beta_deg):
    """F / (rho V^3 t) in closed form equals 2 k times the quadrature of the positive part of
    the MLM pressure (root found numerically), to quadrature accuracy."""
    w = _study()
    beta = math.radians(beta_deg)
    k = 0.5 * math.pi / math.tan(beta)
    xi0 = brentq(lambda x: float(w.mlm_pressure(x, beta)), 0.5, 1.0 - 1e-15, xtol=1e-15)
    integral = quad(lambda x: float(w.mlm_pressure(x, beta)), 0.0, xi0, limit=400)[0]
    assert w.mlm_cf(beta) == pytest.approx(2.0 * k * integral, rel=1e-8)
    # the peak formula is the largest pressure on a fine grid of the positive range
    xi = np.linspace(0.0, xi0, 400001)
    assert w.mlm_cp_max(beta) == pytest.approx(
        2.0 * float(np.max(w.mlm_pressure(xi, beta))), rel=1e-6
    )


@pytest.mark.parametrize("beta_deg", [10, 30])
def test_mlm_binned_peak_matches_bin_averages(beta_deg):
    """The binned MLM peak equals the largest 0.05-wide bin mean of 2 max(p, 0) / (rho V^2) by
    quadrature, and lies below the MLM's pointwise peak (a bin averages the narrow peak down)."""
    w = _study()
    beta = math.radians(beta_deg)
    xi0 = brentq(lambda x: float(w.mlm_pressure(x, beta)), 0.5, 1.0 - 1e-15, xtol=1e-15)
    means = []
    for j in range(20):
        lo, hi = 0.05 * j, min(0.05 * (j + 1), xi0)
        val = quad(lambda x: 2.0 * float(w.mlm_pressure(x, beta)), lo, hi, limit=400)[0]
        means.append(val / 0.05 if hi > lo else 0.0)
    assert w.mlm_cp_binned(beta) == pytest.approx(max(means), rel=1e-8)
    assert w.mlm_cp_binned(beta) < w.mlm_cp_max(beta)


def test_mlm_tends_to_wagner_at_small_deadrise():
    """The MLM corrections vanish as beta -> 0: force and peak over Wagner's tend to 1, the force
    from below and more slowly (its correction is O(tan b log(1 / tan b)))."""
    w = _study()
    ratios = [
        w.mlm_cf(math.radians(d)) / w.wagner_cf(math.radians(d)) for d in (0.1, 1.0, 10.0, 30.0)
    ]
    assert all(a > b for a, b in zip(ratios[:-1], ratios[1:], strict=True))
    assert 0.99 < ratios[0] < 1.0
    b = math.radians(0.1)
    assert w.mlm_cp_max(b) / w.wagner_cp_max(b) == pytest.approx(1.0, abs=1e-4)


def test_richardson_and_convergence_rows():
    """q(h) = 3 + 2 h^2 at h = 1, 1/2, 1/4: order 2 and the Richardson estimate 3 exactly; a
    sequence whose changes change sign, or do not shrink, gets no estimate."""
    w = _study()
    qs = [3.0 + 2.0 * h**2 for h in (1.0, 0.5, 0.25)]
    assert w.observed_order(qs) == pytest.approx(2.0)
    assert w.richardson(qs) == pytest.approx(3.0)
    assert math.isnan(w.richardson([1.0, 2.0, 1.5]))
    assert math.isnan(w.richardson([1.0, 2.0, 4.0]))
    base = {"tank": 1.0, "variant": "", "cf_wagner": 10.0, "cf_mlm": 8.0}
    base |= {"cp_wagner": 5.0, "cp_mlm": 6.0, "cp_mlm_bin": 5.5, "cp_zf": 4.0}
    base |= {"impulse_ratio": 1.0}
    rows = [
        base | {"beta_deg": 30, "n": n, "cf_impulse": q, "cp_max": 4.0 + q / 10}
        for n, q in zip((20, 40, 80), qs, strict=True)
    ]
    conv = w.convergence_rows(rows)
    cf = next(c for c in conv if c["quantity"] == "cf_impulse")
    assert (cf["n1"], cf["n3"], cf["monotone"]) == (20, 80, 1)
    assert cf["richardson"] == pytest.approx(3.0)
    assert cf["finest_over_mlm"] == pytest.approx(qs[2] / 8.0)
    assert math.isnan(cf["finest_over_zf"])
    cp = next(c for c in conv if c["quantity"] == "cp_max")
    assert cp["finest_over_zf"] == pytest.approx((4.0 + qs[2] / 10) / 4.0)
