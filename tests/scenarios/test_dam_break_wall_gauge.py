"""The far-wall gauge's statistics in validation/dam_break_wall_gauge.py, on known signals."""

import numpy as np
import pytest
from validation_script import load

wg = load("dam_break_wall_gauge")


def test_noise_level_of_a_smooth_signal_plus_white_noise():
    """A dry gauge until 0.25 s, then a slowly varying 2-3 kPa signal plus white noise of
    standard deviation 100 Pa, sampled every 1 ms: the arrival is found to the sample, the
    noise level reads 100 Pa within 10 % (330 samples: a statistical spread of ~4 %, the
    smooth part leaves < 1 Pa in the residual), the mean after the impact is the smooth part's."""
    rng = np.random.default_rng(7)
    t = np.arange(0.0, 0.6 + 1e-9, 1e-3)
    smooth = np.where(t >= 0.25, 2500.0 + 500.0 * np.sin(2 * np.pi * 3.0 * (t - 0.25)), 0.0)
    p = smooth + np.where(t >= 0.25, rng.normal(0.0, 100.0, t.size), 0.0)
    p[t < 0.25] = np.nan  # dry gauge
    t_read, p_read = t, np.nan_to_num(p, nan=0.0)
    stats = wg.gauge_statistics(t_read, p_read)
    assert stats.arrival_s == pytest.approx(0.25, abs=1e-3)
    assert stats.noise_rms_pa == pytest.approx(100.0, rel=0.10)
    after = t >= 0.27
    assert stats.mean_after_impact_pa == pytest.approx(np.mean(smooth[after]), abs=15.0)
    assert stats.noise_relative == pytest.approx(stats.noise_rms_pa / stats.mean_after_impact_pa)
    assert stats.peak_pa == pytest.approx(np.max(p_read))


def test_noise_free_signal_reads_almost_no_noise():
    """Without noise the residual is the quadratic fit's error on a 3 Hz sine: below 0.5 Pa."""
    t = np.arange(0.0, 0.6 + 1e-9, 1e-3)
    p = np.where(t >= 0.25, 2500.0 + 500.0 * np.sin(2 * np.pi * 3.0 * (t - 0.25)), 0.0)
    assert wg.gauge_statistics(t, p).noise_rms_pa < 0.5


def test_a_gauge_that_stays_dry_is_an_error():
    t = np.arange(0.0, 0.6, 1e-3)
    with pytest.raises(ValueError, match="no arrival"):
        wg.gauge_statistics(t, np.zeros_like(t))
