"""The seed paper's regular-wave tank under δ-SPHC, shortened (issue 23;
scenarios/wave_tank_delta_sph_2d.toml, validation/delta_sph_wave_tank.py,
docs/validation_delta_sph_wave_tank.md).

CI: the scenario's set-up and the windows it is built for; the linear transient of the ramped
piston (the reference of the CI run) against steady piston theory; a coarse, short version
(d/dx = 10, a 2.5 m tank, 1.8 s; about 15 s on one thread) whose first wave at 0.6 m follows
that linear transient.

Slow (-m slow), from the committed CSVs: the height at 6.37 m against the measured 0.0428 m
with the seed's numerics (strict xfail: not met) and with the scenario's smaller viscosity
(met at d/dx = 15 and 30), and the decay against the artificial viscosity's viscous estimate.
"""

from __future__ import annotations

import cmath
import math
from pathlib import Path

import h5py
import numpy as np
import pytest
from scipy.integrate import trapezoid
from validation_script import load

from mpsfem.fluid_mps.wavemaker import RegularPaddle
from mpsfem.scenario.loader import load_scenario
from mpsfem.simulation import run_fluid

ROOT = Path(__file__).resolve().parents[2]
SCENARIO = ROOT / "scenarios" / "wave_tank_delta_sph_2d.toml"

wt = load("delta_sph_wave_tank")
rw = load("regular_wave")


def test_scenario_is_the_seed_tank_with_windows_for_every_paper_gauge():
    """δ-SPHC (corrected gradient, RK4, h = 1.3 dx, delta = 0.1; seed) on d = 0.266 m at
    d/dx = 15, a linear piston for T = 1 s and H = 0.0428 m, the sponge (not the viscosity ramp)
    from 9 m; every paper gauge before 15 m has an incident-only window of at least 4 periods
    within the run's 12.7 s, and the reflection split's window at 7.5 m lasts 2 periods at the
    d/dx = 15 run's end time. The artificial viscosity (alpha = 3.125e-4, not the seed's 0.02)
    keeps the rule its comment states: Lamb's loss over the 6.37 m, 1 - exp(-2 nu k^2 x / c_g)
    with nu = alpha h c0, at most 5 %, and nu above 5.8e-5 m^2/s, where the paddle's runs
    stopped (cases 15_a0.00015625, 30_a0.0003125)."""
    sc = load_scenario(SCENARIO).scenario
    f = sc.fluid
    assert f.method == "delta-sph" and f.sph.gradient == "corrected"
    assert f.sph.damping == "sponge" and f.sph.integrator == "rk4"
    assert f.spacing == pytest.approx(0.266 / 15)
    assert f.sph.viscosity_form == "seed" and f.sph.smoothing_ratio == 1.3
    tank = rw.tank_from_resolved(sc.model_dump())
    c0 = 10.0 * math.sqrt(9.81 * wt.DEPTH)  # seed eq. 1 with U = 0.2 m/s < sqrt(g d)
    h_c0 = f.sph.smoothing_ratio * f.spacing * c0  # nu = alpha h c0 (seed eq. 3 as printed)
    nu = f.sph.viscosity_alpha * h_c0
    lamb = 2.0 * nu * tank.wave.k**2 / tank.wave.group_velocity  # Lamb 1932, art. 348
    assert 1.0 - math.exp(-lamb * wt.TARGET_GAUGE) <= wt.HEIGHT_TOLERANCE
    assert nu > 1.5 * (wt.ANTUONO_ALPHA / 16) * h_c0  # 1.5 x the stopped runs' nu
    assert tank.wave.depth == 0.266 and tank.wave.period == 1.0 and tank.wave_height == 0.0428
    assert tank.theory_height == pytest.approx(0.0428, rel=1e-12)
    assert tank.sponge_start == 9.0
    gauges = {p.position[0] for p in sc.probes}
    assert set(wt.PAPER_GAUGES) <= gauges and set(wt.SPLIT_GAUGES) <= gauges
    for x in wt.PAPER_GAUGES:
        w0, w1 = rw.incident_window(tank, x)
        assert (min(w1, sc.run.end_time) - w0) / tank.wave.period >= 4.0
    r0, r1 = rw.reflection_window(tank, min(wt.SPLIT_GAUGES), wt.END_TIME[15])
    assert (r1 - r0) / tank.wave.period >= rw.MIN_PERIODS


def test_linear_transient_settles_to_piston_theory():
    """linear_piston_eta, 6 periods after the ramp at 2.37 m: the first harmonic is H/2 with
    phase omega t0 + k x (the paddle's e^{-i omega t} phase; regular_wave.py's convention) to
    the FFT's error. 1e-3: the forerunners of the half-cosine ramp, dispersed, are below that
    by then (measured 2e-4)."""
    pad = RegularPaddle(0.0428, 1.0, 0.266, rw.GRAVITY, 1.0, 0.2)
    t = np.arange(0.0, 14.0, 0.01)
    x = 2.37
    eta = wt.linear_piston_eta(pad, x, t)
    z, _ = rw.harmonic_fit(t, eta, pad.omega, (8.0, 14.0))
    assert 2 * abs(z) == pytest.approx(0.0428, rel=1e-3)
    assert abs(cmath.phase(z * cmath.exp(-1j * (pad.omega * 0.2 + pad.k * x)))) < 1e-3
    assert np.max(np.abs(eta[t < 0.2])) < 1e-4 * 0.0428  # causal to the FFT's wrap


def test_wide_kernel_cases_are_the_seeds_alpha_s_2():
    """The h = 2.0 dx cases (the seed's alpha_s = 2.0, Table 2's last column): h = 2.0 dx, the
    seed's alpha = 0.02 under viscosity_form 'antuono'; at both resolutions the paddle (0.08 m)
    is thicker than the support 2h, the time-step cap stays above the acoustic step 0.8 h / c0
    (it scales with h), and the top-particle gauges look one spacing wide. The equal-viscosity
    diagnostics have nu = alpha h c0 / 8 equal to cases 15_a0.0025's and 30_a0.0025's (seed
    form, h = 1.3 dx)."""
    all_cases = wt.cases()
    resolved = {}
    labels = ("15_h2.0", "30_h2.0", "15_h2.0_nu1.3", "30_h2.0_nu1.3", "15_a0.0025", "30_a0.0025")
    for label in labels:
        ratio, overrides = all_cases[label]
        sc = load_scenario(SCENARIO, overrides).scenario
        sph, dx = sc.fluid.sph, sc.fluid.spacing
        assert dx == pytest.approx(wt.DEPTH / ratio)
        h = sph.smoothing_ratio * dx
        paddle = sc.fluid.walls[1]
        assert paddle.upper[0] - paddle.lower[0] >= 2.0 * h
        c0 = 10.0 * math.sqrt(9.81 * wt.DEPTH)  # seed eq. 1 with U = 0.2 m/s < sqrt(g d)
        assert sc.fluid.time_step.dt_max > 0.8 * h / c0
        assert all(sc.probes[i].half_width == pytest.approx(dx) for i in wt.TOP_PROBES)
        scale = 1.0 if sph.viscosity_form == "seed" else 1.0 / 8.0  # 1 / (2 (n + 2)), n = 2
        resolved[label] = (sph.smoothing_ratio, sph.viscosity_form, sph.viscosity_alpha, scale)
    for label in ("15_h2.0", "30_h2.0"):
        assert resolved[label][:3] == (2.0, "antuono", 0.02)
    nu = {k: r * a * s for k, (r, _, a, s) in resolved.items()}  # nu / (dx c0)
    assert nu["15_h2.0_nu1.3"] == pytest.approx(nu["15_a0.0025"], rel=1e-12)
    assert nu["30_h2.0_nu1.3"] == pytest.approx(nu["30_a0.0025"], rel=1e-12)
    assert nu["15_h2.0"] == pytest.approx(nu["15_a0.0025"] * 2.0 / 1.3, rel=1e-12)


NEAR = 0.6  # m, 2.3 depths from the paddle: evanescent modes exp(-pi x / d) < 1e-3
COARSE = 10  # d / dx: H = 1.6 spacings
COARSE_END = 1.8  # s: the ramp's first trough (1.27 s) and the rise to the first crest


@pytest.fixture(scope="module")
def coarse_run(tmp_path_factory):
    gauge = (
        f'{{name="gauge_{NEAR:.2f}", kind="wave_gauge", position=[{NEAR}], reference_level=0.266}}'
    )
    loaded = load_scenario(
        SCENARIO,
        [
            f"fluid.spacing={0.266 / COARSE!r}",
            "output.snapshot_interval=0",
            "output.checkpoint_interval=0",
            "fluid.blocks.0.upper=[2.5, 0.266]",
            "fluid.walls.0.upper=[2.5, 0.45]",
            "fluid.sponges.0.start=1.5",
            "fluid.sponges.0.end=2.5",
            f"probes=[{gauge}]",
            # the seed's alpha, at which the tolerances below were set and measured; with the
            # scenario's 3.125e-4 (nu = 1.75e-4 m^2/s at d/dx = 10) the trough reads 24 % deep
            # (-8.71 against -7.01 mm) and the RMS difference 0.18: too near the 25 % to be
            # a test of the paddle, so CI keeps the run these bounds were made for
            "fluid.sph.viscosity_alpha=0.02",
        ],
    )
    out = tmp_path_factory.mktemp("wave_tank") / "coarse.h5"
    run_fluid(loaded, out, progress=False, end_time=COARSE_END)
    with h5py.File(out, "r") as h5:
        g = h5["probes"][f"gauge_{NEAR:.2f}"]
        return str(h5.attrs["status"]), g["time"][:], g["value"][:]


def test_coarse_run_makes_the_linear_wave_at_the_first_gauge(coarse_run):
    """At 0.6 m the ramped paddle's first large excursion is a trough (the ramp weights the
    paddle's first backward stroke more than its first forward one): the δ-SPH record's minimum
    has the linear transient's sign, its value within 25 % and its time within 0.05 s; the
    whole record from t0 on within a normalised RMS difference of 0.45.

    Tolerances (set from the method's expected error, then measured): at d/dx = 10 the wave
    height spans 1.6 spacings, and the MPS study's coarse tank (H_w = 1.75 spacings) scattered
    by +-10 % with a 10 % decay over its first gauge (tests/scenarios/test_regular_wave.py):
    25 % on the trough. The first crest (1.75 s) is steeper, ka grows with the ramp, and a
    crest 1.6 spacings high is where the kernel gauge and the free surface are least resolved:
    it reads 35 % low here (12.7 against 18.7 mm), which dominates the RMS (measured 0.30).
    0.45 still fails every gross error of a paddle: a reversed paddle (about 2), one that does
    not move (1), half the stroke (above 0.5 with this run's own error). 0.05 s is 0.08 rad:
    a phase speed 10 % off over the 0.6 m, or the paddle law a tenth of a period late, fails it."""
    status, t, eta = coarse_run
    assert status == "finished"
    pad = RegularPaddle(0.0428, 1.0, 0.266, rw.GRAVITY, 1.0, 0.2)
    lin = wt.linear_piston_eta(pad, NEAR, t)
    sel = t >= pad.start_time
    i_lin, i_sph = np.argmin(lin), np.argmin(eta)
    nrms = math.sqrt(np.mean((eta[sel] - lin[sel]) ** 2) / np.mean(lin[sel] ** 2))
    print(
        f"d/dx = {COARSE}: trough {1e3 * eta[i_sph]:.2f} mm at {t[i_sph]:.2f} s, linear "
        f"{1e3 * lin[i_lin]:.2f} mm at {t[i_lin]:.2f} s; normalised RMS difference {nrms:.3f}"
    )
    assert lin[i_lin] < -0.005  # the reference has the trough the docstring describes
    assert eta[i_sph] == pytest.approx(lin[i_lin], rel=0.25)
    assert abs(t[i_sph] - t[i_lin]) <= 0.05
    assert nrms <= 0.45


def _csv_rows(path: Path) -> list[dict[str, str]]:
    if not path.is_file():
        pytest.skip(f"{path} missing: python validation/delta_sph_wave_tank.py")
    return rw.read_csv(path)


@pytest.mark.slow
@pytest.mark.xfail(
    strict=True,
    reason="issue 23's target is not met: at d/dx = 15 with the seed's alpha = 0.02 (seed eq. 3 "
    "as printed: nu = alpha h c0) the wave reaches 6.37 m at 0.0028 m, -93 % "
    "(docs/validation_delta_sph_wave_tank.md); with alpha / 8 (viscosity_form = 'antuono') "
    "-20 % at d/dx = 15 and -9.8 % at d/dx = 30; with h = 2.0 dx -30 % and -17 % (the "
    "scenario's own nu = 1.2e-4 m^2/s meets it at both: "
    "test_low_viscosity_meets_the_height_at_both_resolutions); strict, "
    "so a run that meets it shows up",
)
def test_height_at_6_37_m_against_the_measurement():
    """The committed CSV (validation/delta_sph_wave_tank.py): at every resolution run in the
    full tank (cases "15", "30": the seed's numerics, alpha = 0.02; "15_a0.0025", "30_a0.0025": alpha / 8,
    the 'antuono' reading the paper's results need; "15_h2.0", "30_h2.0": the seed's wider
    kernel h = 2.0 dx with that reading), the first-harmonic height at 6.37 m within 5 % of the
    measured 0.0428 m (issue 23; seed Table 2)."""
    rows = [
        r
        for r in _csv_rows(wt.CSV)
        if r["case"] in ("15", "30", "15_a0.0025", "30_a0.0025", "15_h2.0", "30_h2.0")
        and r["gauge"] == "kernel"
        and math.isclose(float(r["x"]), wt.TARGET_GAUGE)
    ]
    assert rows
    for r in rows:
        h = float(r["height_first_harmonic"])
        print(f"d/dx = {r['d_over_dx']}: H(6.37 m) = {h:.5f} m, {100 * (h / 0.0428 - 1):+.1f} %")
        assert abs(h / wt.MEASURED_HEIGHT - 1.0) <= wt.HEIGHT_TOLERANCE


@pytest.mark.slow
def test_decay_is_the_artificial_viscosity_and_generation_is_right():
    """The committed summary: (1) the measured spatial decay delta of the incident heights is
    Lamb's viscous decay 2 nu k^2 / cg with nu = alpha h c0 (seed eq. 3 with phi's 2 (n + 2))
    within a factor 1.5, for alpha = 0.02 and for alpha / 8, and at h = 2.0 dx (nu = alpha h c0
    / 8 with the 'antuono' form: 1.54 times the h = 1.3 dx viscosity at the same alpha, and at
    the h = 1.3 dx viscosity). The factor 1.5: Lamb's estimate
    knows nothing of the kernel's truncation at the surface or of the particles' noise in a
    wave 2.4 spacings high; it is there to tell nu = alpha h c0 from alpha h c0 / 8, a factor 8
    apart (measured 1.28, 0.80, at d/dx = 30 over 1-2.37 m 0.91, and over 1-6.37 m with alpha / 8
    0.74; h = 2.0 dx: 0.90 and 0.88 at d/dx = 15, 0.88 and 0.83 at 30). Not the short-tank d/dx = 30
    alpha / 8 case: its estimated 3 % change over 1.37 m is
    not resolved by three short fits. (2) With alpha / 8, where the wave keeps its height, the
    exponential fit extrapolated to the paddle is the design height within 5 % (the paddle law
    and the fit; measured 1.000) and the wave number linear theory's within 2 % (a 2 % error in
    phase speed over 6 m is 0.6 rad; measured -0.5 %)."""
    rows = {r["case"]: r for r in _csv_rows(wt.SUMMARY_CSV)}
    cases = ("15", "15_a0.0025", "30_short", "30_a0.0025", "15_h2.0", "15_h2.0_nu1.3", "30_h2.0",
             "30_h2.0_nu1.3")  # fmt: skip
    for case in cases:
        if case not in rows:
            pytest.skip(f"case {case} not in {wt.SUMMARY_CSV}")
        r = rows[case]
        ratio = float(r["decay_per_m"]) / float(r["decay_lamb_per_m"])
        print(f"{case}: delta {float(r['decay_per_m']):.4f} 1/m = {ratio:.2f} x Lamb's")
        assert 1 / 1.5 <= ratio <= 1.5
    a = rows["15_a0.0025"]
    assert float(a["ratio_at_paddle"]) == pytest.approx(1.0, abs=0.05)
    assert float(a["k_measured"]) == pytest.approx(float(a["k_theory"]), rel=0.02)


@pytest.mark.parametrize("width", [math.inf, 1.0, 0.5])
def test_flume_decay_is_the_stokes_layers_energy_balance(width):
    """Hunt's (1952) closed form for the flume's own loss against the energy balance it stands
    for, evaluated numerically: a linear wave of amplitude a (u = a omega cosh k(z + d) /
    sinh kd, w = a omega sinh k(z + d) / sinh kd) over a no-slip wall carries a Stokes layer
    whose velocity defect is U (exp(-s) cos(omega t - s)), s = zeta / delta_s, delta_s =
    sqrt(2 nu / omega); its dissipation per unit wall area, rho nu <(du/dzeta)^2> integrated
    over zeta and averaged over a period, is summed over the bottom (u) and both side walls
    (u and w, integrated over the depth); the amplitude decays at D / (2 E c_g b), E = rho g
    a^2 / 2 per unit area. Quadrature to 1e-9, so the closed form must agree to 1e-6."""
    rho, g, nu, d, a = 1000.0, 9.81, 1.0e-6, wt.DEPTH, 0.01
    omega = 2.0 * math.pi / wt.WAVE_PERIOD
    k = wt.wave_number(omega, d, g)
    delta_s = math.sqrt(2.0 * nu / omega)
    # dissipation per unit wall area for a wall velocity amplitude U: the Stokes layer's shear
    # du/dzeta = (U / delta_s) e^{-s} (cos(wt - s) - sin(wt - s)) (amplitude sqrt 2 U e^-s /
    # delta_s, mean square U^2 e^{-2s} / delta_s^2), integrated over zeta = delta_s s
    s = np.linspace(0.0, 40.0, 400_001)
    shear_ms = np.exp(-2.0 * s) / delta_s**2  # per U^2
    per_u2 = rho * nu * trapezoid(shear_ms, s * delta_s)
    z = np.linspace(-d, 0.0, 200_001)
    scale = (a * omega / math.sinh(k * d)) ** 2
    bottom = per_u2 * scale  # u at z = -d: cosh(0) = 1
    side = per_u2 * scale * trapezoid(np.cosh(k * (z + d)) ** 2 + np.sinh(k * (z + d)) ** 2, z)
    cg = 0.5 * omega / k * (1.0 + 2.0 * k * d / math.sinh(2.0 * k * d))
    energy_flux = 0.5 * rho * g * a**2 * cg  # per unit width
    if math.isinf(width):
        delta = bottom / (2.0 * energy_flux)
    else:
        delta = (bottom * width + 2.0 * side) / (2.0 * energy_flux * width)
    assert wt.flume_decay_per_m(k, d, omega, width, nu) == pytest.approx(delta, rel=1e-6)


@pytest.mark.slow
def test_height_at_6_37_m_converges_with_the_spacing():
    """The committed CSV, alpha / 8 (viscosity_form 'antuono''s reading of the seed's 0.02) at
    h = 1.3 dx: the error of the first-harmonic height at 6.37 m against the measured 0.0428 m
    falls at every halving of dx (d/dx = 15, 30, 60), at an observed order of at least 0.5.
    The artificial viscosity alpha h c0 / 8 is proportional to dx, so the viscous loss over a
    fixed distance is first order (Lamb: delta = 2 nu k^2 / c_g); 0.5 allows for the flume's
    own loss (0.9-3.3 %, `flume_decay_per_m`) and the discretisation error, which do not fall
    with dx at that rate. The order over 15 -> 30 is printed for the record."""
    rows = {
        r["case"]: float(r["error_vs_measured_pct"])
        for r in _csv_rows(wt.CSV)
        if r["gauge"] == "kernel" and math.isclose(float(r["x"]), wt.TARGET_GAUGE)
    }
    cases = ("15_a0.0025", "30_a0.0025", "60_a0.0025")
    for case in cases:
        if case not in rows:
            pytest.skip(f"case {case} not in {wt.CSV}: python validation/delta_sph_wave_tank.py")
    errors = [abs(rows[c]) for c in cases]
    orders = [math.log2(errors[i] / errors[i + 1]) for i in range(2)]
    print(f"|error| at 6.37 m: {errors} %, observed orders {orders}")
    assert errors[0] > errors[1] > errors[2]
    assert min(orders) >= 0.5


@pytest.mark.slow
def test_low_viscosity_meets_the_height_at_both_resolutions():
    """The committed CSVs, the low-viscosity cases (docs/validation_delta_sph_wave_tank.md,
    'Less artificial viscosity'), seed-form alpha at h = 1.3 dx: alpha / 32 (6.25e-4:
    "15_a0.000625", "30_a0.000625"), alpha / 64 (3.125e-4, the scenario's: "15_a0.0003125"),
    and alpha = 0 at h = 2.0 dx (density diffusion only: "15_h2.0_a0", "30_h2.0_a0").

    (1) The scenario's nu = alpha h c0 = 1.2e-4 m^2/s ("15_a0.0003125" at d/dx = 15,
    "30_a0.000625" at 30) puts the first-harmonic height at 6.37 m within 5 % of the measured
    0.0428 m at both resolutions (issue 23's target), as does alpha = 0 at h = 2.0 dx at
    d/dx = 30. (2) Every finished low-viscosity case loses from 2.37 to 6.37 m what Lamb's decay
    for its nu predicts, within the gauges' scatter: 2 nu k^2 / c_g over 4 m within 3 % (two
    fits of 4-8 periods scatter by about 1 % each: 2 sigma of their ratio). (3) Below that nu
    the paddle does not hold: nu = 0 at h = 1.3 dx ("15_a0") and nu = 5.8e-5 ("15_a0.00015625",
    "30_a0.0003125") stop with the named Mach error (a particle driven into the moving
    paddle); so do alpha = 0 with δ+-SPH shifting ("15_a0_shift") and with the wetted wall
    pressure ("15_a0_wetted", a particle out of the domain under the paddle). (4) With clamped
    walls (wall_pressure = "clamped", p_w >= 0) alpha = 0 and alpha / 128 hold at d/dx = 15
    ("15_a0_clamped", "15_a0.00015625_clamped"), alpha = 0 at 30 ("30_a0_clamped"), and all
    are within 5 % too."""
    summary = {r["case"]: r for r in _csv_rows(wt.SUMMARY_CSV)}
    gauges = {
        (r["case"], float(r["x"])): float(r["height_first_harmonic"])
        for r in _csv_rows(wt.CSV)
        if r["gauge"] == "kernel"
    }
    clamped = ("15_a0_clamped", "15_a0.00015625_clamped", "30_a0_clamped")
    finished = ("15_a0.000625", "30_a0.000625", "15_a0.0003125", "15_h2.0_a0", "30_h2.0_a0",
                *clamped)  # fmt: skip
    stopped = ("15_a0", "15_a0.00015625", "30_a0.0003125", "15_a0_shift", "15_a0_wetted")
    for case in (*finished, *stopped):
        if case not in summary:
            pytest.skip(
                f"case {case} not in {wt.SUMMARY_CSV}: python validation/delta_sph_wave_tank.py"
            )
    for case in finished:
        s = summary[case]
        assert s["status"] == "finished"
        h237, h637 = gauges[(case, 2.37)], gauges[(case, wt.TARGET_GAUGE)]
        lamb = 1.0 - math.exp(-float(s["decay_lamb_per_m"]) * (wt.TARGET_GAUGE - 2.37))
        loss = 1.0 - h637 / h237
        err = h637 / wt.MEASURED_HEIGHT - 1.0
        print(f"{case}: H(6.37) {h637:.5f} m ({100 * err:+.1f} %), loss 2.37-6.37 m "
              f"{100 * loss:+.1f} % (Lamb {100 * lamb:.1f} %)")  # fmt: skip
        assert loss == pytest.approx(lamb, abs=0.03)
        if case in ("15_a0.0003125", "30_a0.000625", "30_h2.0_a0", *clamped):
            assert abs(err) <= wt.HEIGHT_TOLERANCE
    nu = {c: float(summary[c]["nu_artificial"]) for c in ("15_a0.0003125", "30_a0.000625")}
    assert nu["15_a0.0003125"] == pytest.approx(nu["30_a0.000625"], rel=1e-9)
    for case in stopped:
        stop = summary[case]["status"]
        assert stop.startswith("failed")
        assert "max_mach" in stop or "left the domain" in stop
