"""Solitary-wave tank (issue 5; thesis ch. 3.3, references.md sections 6 and 9).

CI: a coarse, short version of scenarios/solitary_wave_2d.toml (about 20 s on one thread):
l0 = H/10 = 0.0114 m (10 particle layers over the depth, 2.2k fluid particles), a 1.5 m tank with
the sponge (alpha_s = 50) over its last 0.5 m, A/H = 0.3, 2.8 s simulated. It checks that the
Goring paddle makes a crest of the design amplitude at the time the design wave predicts, and that
the sponge takes it out. The analysis is validation/wave_tank.py's (crest fit, theory).

Slow (-m slow): the full-resolution cases of validation/wave_tank.py (l0 = H/28, the 2.5 m tank,
A/H = 0.2 ... 0.5) against the 5 % amplitude target at x = 1.2 m, and the same at the thesis's
l0 = 0.002 m (H/57) with the convergence check that the profile's RMS deviation from Grimshaw's
falls there by more than its spread between realisations. They reuse a finished results file in
validation/results/ and run the case otherwise (10-22 min each on one thread at H/28, 17-27 min
on two threads at 0.002 m).
"""

import math
from pathlib import Path

import h5py
import numpy as np
import pytest
from validation_script import load

from mpsfem.scenario.loader import load_scenario
from mpsfem.simulation import run_fluid

ROOT = Path(__file__).resolve().parents[2]


wt = load("wave_tank")

H = wt.DEPTH
RATIO = 0.3
L0_COARSE = H / 10  # 10 layers: the coarsest at which the crest is still 3 spacings high
TANK = 1.5  # m, shortened from 2.5 m so the wave reaches the sponge's far end within 2.8 s
SPONGE = (1.0, 1.5)  # last 0.5 m, as in the thesis
NEAR, ENTRY, FAR = 0.6, 1.0, 1.4  # gauges: near the paddle, sponge entry, 0.1 m before the wall
END_TIME = 2.8  # the crest reaches x = 1.4 m at about 2.3 s (wave_tank.predicted_crest_time)


@pytest.fixture(scope="module")
def coarse_run(tmp_path_factory):
    gauges = ",".join(
        f'{{name="{wt.gauge_name(x)}", kind="wave_gauge", position=[{x}], reference_level={H}}}'
        for x in (NEAR, ENTRY, FAR)
    )
    loaded = load_scenario(
        ROOT / "scenarios" / "solitary_wave_2d.toml",
        [
            f"fluid.spacing={L0_COARSE!r}",
            "fluid.time_step.dt_max=2e-3",  # Courant 0.2 l0 / u allows 4.5e-3 s at 0.5 m/s
            "output.snapshot_interval=0",
            f"fluid.blocks.0.upper=[{TANK}, {H}]",
            f"fluid.walls.0.upper=[{TANK}, 0.3]",
            f"fluid.sponges.0.start={SPONGE[0]}",
            f"fluid.sponges.0.end={SPONGE[1]}",
            f"fluid.walls.1.motion.amplitude={RATIO * H!r}",
            f"probes=[{gauges}]",
        ],
    )
    out = tmp_path_factory.mktemp("solitary") / "coarse.h5"
    run_fluid(loaded, out, progress=False, end_time=END_TIME)
    start = loaded.scenario.fluid.walls[1].motion.start_time
    with h5py.File(out, "r") as h5:
        records = {x: wt.read_gauge(h5, x) for x in (NEAR, ENTRY, FAR)}
        status = h5.attrs["status"]
    return records, wt.SolitaryWave(RATIO * H), start, status


def test_crest_fit_recovers_exact_profiles():
    """The analysis itself: on the exact first-order profile sampled every 0.01 s (crest between
    samples), the crest fit gives A to 0.2 % (its known bias is -0.15 %, the quartic term of
    sech^2 over the fit window) and t_c to 2e-4 s, for every A/H of the validation."""
    t = np.arange(0.0, 5.0 + 1e-9, 0.01)
    for ratio in wt.RATIOS:
        wave = wt.SolitaryWave(ratio * H)
        assert wave.grimshaw(np.array([2.0]), 2.0)[0] == pytest.approx(wave.amplitude, rel=1e-12)
        for t_c in (2.0, 2.0033, 2.0071):
            t_fit, a_fit = wt.crest(t, wave.first_order(t, t_c), wave, t_c + 0.1)
            assert abs(a_fit / wave.amplitude - 1.0) < 2e-3
            assert abs(t_fit - t_c) < 2e-4


def test_paddle_makes_the_design_crest_at_the_near_gauge(coarse_run):
    """Crest at x = 0.6 m within l0/2 of A and within 0.1 s of the design wave's arrival.

    Tolerance from the resolution: a gauge reads the top particle's centre plus l0/2, so it
    knows the surface only to within a particle's cell; l0/2 = 0.0057 m is 17 % of A here.
    Measured with the kernel gauge: +5.0 % (crest 0.002 s early); the top-particle gauge at
    l0 = H/28 read -0.2 % (docs/validation_wave_tank.md). A paddle with a wrong stroke (A grows like S^2) or timing
    fails it. 0.1 s is a 15 % crest-speed error over the 0.53 m from the paddle's mid-stroke."""
    records, wave, start, status = coarse_run
    assert status == "finished"
    t, eta = records[NEAR]
    t_c, a = wt.crest(t, eta, wave, wt.predicted_crest_time(wave, start, NEAR))
    t_pred = wt.predicted_crest_time(wave, start, NEAR)
    print(
        f"l0 = H/10: crest at x = {NEAR} m {a * 1e3:.2f} mm vs A = {wave.amplitude * 1e3:.2f} mm "
        f"({(a / wave.amplitude - 1) * 100:+.1f} %), at {t_c:.3f} s vs {t_pred:.3f} s"
    )
    assert abs(a - wave.amplitude) <= 0.5 * L0_COARSE
    assert abs(t_c - t_pred) < 0.1


def test_sponge_damps_the_wave(coarse_run):
    """The wave enters the sponge (at its inner edge the 0.11 s running mean of eta reaches at
    least 0.9 A) and 0.1 m before the end wall it stays below 0.6 A. Measured once without the
    sponge (fluid.sponges = []), the same run reads 1.55 A there by 2.8 s (the wall reflects the
    wave: up to 2 A) and 1.00 A at the inner edge (top-particle gauge); with it 0.42 A and
    1.35 A (kernel gauge; the sponge's inner part reflects: docs/validation_wave_tank.md)."""
    records, wave, start, _ = coarse_run
    peak = {}
    for x in (ENTRY, FAR):
        t, eta = records[x]
        smooth = wt.running_mean(eta, 11) - wt.still_level(t, eta, start)
        peak[x] = float(np.nanmax(np.abs(smooth))) / wave.amplitude
    print(f"max |eta| / A: sponge entry {peak[ENTRY]:.2f}, end of the sponge {peak[FAR]:.2f}")
    assert peak[ENTRY] >= 0.9
    assert peak[FAR] < 0.6


def test_long_wave_model_reflects_a_pulse_whole_without_sponge():
    """The 1D long-wave model of the sponge (wave_tank.long_wave_sponge_record), with the zone
    switched off (alpha_s = 0) in front of a wall at 1.6 m: the pulse comes back whole and the
    reflection metric reads the running mean's peak of a sech^2 pulse of the linear speed,
    1 - (k c0 0.055 s)^2 / 3 (0.981 at A/H = 0.3), to 0.5 %. A wrong wave speed puts the echo
    outside the window or shifts the crest time; a lossy or reflecting upstream end changes
    the height. At a refined grid (dx / 2) the sponge's metric moves by less than 0.1 % of A."""
    wave = wt.SolitaryWave(RATIO * H)
    t, eta, t_c = wt.long_wave_sponge_record(wave, 0.0, sponge_start=1.5, tank_end=1.6)
    c0 = math.sqrt(wt.GRAVITY * H)
    half = wt.GORING_HALF_SPAN / wave.k
    assert t_c == pytest.approx(2.0 * half / c0, abs=0.011)  # crest starts 2 half-lengths upstream
    r, _ = wt.reflection(t, eta, wave, t_c, wt.REFLECTION_GAUGE, 0.0, 1.5)
    expected = 1.0 - (wave.k * c0 * 0.055) ** 2 / 3.0
    print(f"no sponge: metric {r:.4f} vs {expected:.4f}")
    assert r == pytest.approx(expected, rel=5e-3)
    coarse = wt.long_wave_sponge_reflection(wave, 50.0)
    t, eta, t_c = wt.long_wave_sponge_record(wave, 50.0, dx=0.00125)
    fine = wt.reflection(t, eta, wave, t_c, wt.REFLECTION_GAUGE, 0.0)[0]
    assert abs(coarse - fine) < 1e-3


def test_long_wave_model_predicts_the_mps_sponge_reflection():
    """The MPS tank at the thesis's resolution (validation/results/wave_tank_0.002.csv,
    committed; thesis sponge alpha_s = 50 over 2.0-2.5 m) sends back 39.6-48.9 % of A past
    x = 1.0 m; the 1D long-wave model of the same sponge predicts 40.4-51.4 %. Tolerance 5 % of
    A: the model has neither the wave's dispersion nor its nonlinearity (its speed c0 is
    sqrt(1 + A/H) below the solitary wave's, 10-22 %, which moves the echo in the window), and
    the MPS number carries the gauge's noise (0.5-0.8 % of A). It shows the reflection is what
    a velocity sponge of this length does to a wave this long in a closed tank, not a defect
    of the MPS sponge, so the model's scan of other zones (docs/validation_wave_tank.md) can be
    trusted to about this tolerance."""
    csv = ROOT / "validation" / "results" / "wave_tank_0.002.csv"
    rows = np.genfromtxt(csv, delimiter=",", names=True, dtype=None, encoding="utf-8")
    for row in rows:
        wave = wt.SolitaryWave(float(row["a_over_h"]) * H)
        model = wt.long_wave_sponge_reflection(wave, 50.0)
        measured = float(row["reflection_pct"]) / 100.0
        print(f"A/H = {row['a_over_h']}: MPS {measured:.3f} A, long-wave model {model:.3f} A")
        assert abs(model - measured) < 0.05


@pytest.mark.slow
@pytest.mark.parametrize("ratio", wt.RATIOS)
def test_full_resolution_amplitude_within_5_percent(ratio):
    """l0 = H/28, the thesis tank: crest at x = 1.2 m within 5 % of A (issue 5 target). Measured
    on the current code -3.5 / -2.2 / -3.1 / -0.4 %; three realisations of A/H = 0.2 (pressure
    tolerance 1e-6, 5e-7, 2e-6) read -3.5, +0.1 and -1.3 %, so a single run's crest moves by up
    to 4 points of A (docs/validation_wave_tank.md): the target is met with less margin than
    that spread at A/H = 0.2 and 0.4."""
    spacing = wt.spacing_for(0.004)
    out = wt.case_path("0.004", ratio)
    out.parent.mkdir(parents=True, exist_ok=True)
    status = wt.ensure_case(ratio, spacing, out, threads=1, retry=False)
    assert status == "finished"
    res = wt.analyse(out)
    print(
        f"A/H = {ratio}: amplitude {res.amplitude_error_pct:+.2f} %, RMS first order "
        f"{res.rms_first_order_pct:.2f} %, Grimshaw {res.rms_grimshaw_pct:.2f} %, crest speed "
        f"{res.speed_error_first_order_pct:+.2f} % of c, reflection {res.reflection_pct:.1f} %"
    )
    assert math.isfinite(res.amplitude_error_pct)
    assert abs(res.amplitude_error_pct) <= 100.0 * wt.AMPLITUDE_TARGET


#: spread of the RMS deviation from Grimshaw's profile over three H/28 realisations of A/H = 0.2
#: (pressure tolerance 1e-6 / 5e-7 / 2e-6: 4.63 / 5.35 / 4.47 %), % of A
REALISATION_SPREAD_RMS_PCT = 0.9


@pytest.mark.slow
@pytest.mark.parametrize("ratio", wt.RATIOS)
def test_thesis_resolution_amplitude_within_5_percent_and_converging(ratio):
    """l0 = 0.002 m (H/57, thesis Table 3-1): crest at x = 1.2 m within 5 % of A, and the
    profile converges: its RMS deviation from Grimshaw's third-order profile at 1.2 m falls from
    H/28 by more than 0.9 % of A, the spread of three H/28 realisations of A/H = 0.2 (4.5-5.4 %;
    docs/validation_wave_tank.md). The crest's loss between 0.6 and 1.6 m, the check before,
    is printed only: at H/28 it spreads by 4.7 points of A between realisations (-4.0 to +0.7
    % at A/H = 0.2), more than the loss it was to measure."""
    res = {}
    for l0 in ("0.004", "0.002"):
        out = wt.case_path(l0, ratio)
        out.parent.mkdir(parents=True, exist_ok=True)
        status = wt.ensure_case(ratio, wt.spacing_for(float(l0)), out, threads=2, retry=False)
        assert status == "finished"
        res[l0] = wt.analyse(out)
    decay = {k: r.amplitude_error_x0_6_pct - r.amplitude_error_x1_6_pct for k, r in res.items()}
    fine = res["0.002"]
    print(
        f"A/H = {ratio}, l0 = 0.002 m: amplitude {fine.amplitude_error_pct:+.2f} %, RMS Grimshaw "
        f"{fine.rms_grimshaw_pct:.2f} %, crest speed {fine.speed_error_first_order_pct:+.2f} % of "
        f"c; crest loss 0.6 -> 1.6 m {decay['0.004']:.1f} % (H/28) -> {decay['0.002']:.1f} % of A"
    )
    print(
        f"RMS Grimshaw {res['0.004'].rms_grimshaw_pct:.2f} % (H/28) -> {fine.rms_grimshaw_pct:.2f} %"
    )
    assert abs(fine.amplitude_error_pct) <= 100.0 * wt.AMPLITUDE_TARGET
    assert fine.rms_grimshaw_pct < res["0.004"].rms_grimshaw_pct - REALISATION_SPREAD_RMS_PCT
