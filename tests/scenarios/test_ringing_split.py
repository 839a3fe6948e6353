"""validation/momentum_budget.py's ringing measure split into the load's own course (an 11 ms
cubic Savitzky-Golay fit) and the noise about it (issue 20)."""

import h5py
import numpy as np
import pytest
from validation_script import load

mb = load("momentum_budget")


def _probe(path, t, f):
    with h5py.File(path, "w") as h5:
        g = h5.create_group("probes/force")
        g["time"] = t
        g["value"] = np.c_[f, np.zeros_like(f)]


def test_a_smooth_load_rings_only_in_its_fit_and_noise_only_in_the_residual(tmp_path):
    """F = 300 sin(pi t / 0.13) N/m over 0.12-0.25 s at 1 ms: the fit's jump RMS is the
    signal's own, pi dt / 0.13 / sqrt 2 = 0.0171 of the peak (2 %: the sampled sine's RMS over
    a window that is not a whole number of its steps), the residual's the fit's error (< 1e-3).
    With white noise n added the fit is linear, so the residual is the noise's own residual
    about its fit plus the sine's (~0): its jump RMS over the noisy peak must equal that of
    n - fit(n) to 1 %."""
    from scipy.signal import savgol_filter

    t = np.arange(0.10, 0.27, 1e-3)
    f = 300.0 * np.sin(np.pi * (t - 0.12) / 0.13)
    _probe(tmp_path / "a.h5", t, f)
    fit, residual = mb.ringing_split(tmp_path / "a.h5", "force", 0.12, 0.25)
    assert fit == pytest.approx(np.pi * 1e-3 / 0.13 / np.sqrt(2.0), rel=0.02)
    assert residual < 1e-3
    n = np.random.default_rng(3).normal(0.0, 20.0, t.size)
    _probe(tmp_path / "b.h5", t, f + n)
    fit_n, residual_n = mb.ringing_split(tmp_path / "b.h5", "force", 0.12, 0.25)
    sel = (t >= 0.12) & (t <= 0.25)
    rn = n - savgol_filter(n, 11, 3, mode="interp")
    expect = np.sqrt(np.mean(np.diff(rn[sel]) ** 2)) / np.abs(f + n)[sel].max()
    assert residual_n == pytest.approx(expect, rel=0.01)
    assert fit_n < residual_n  # the fit keeps the smaller part of the noise's jumps
