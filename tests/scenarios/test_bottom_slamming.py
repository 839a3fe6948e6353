"""2D bottom slamming of a horizontal plate by a solitary wave (issue 5; thesis ch. 5.1).

CI: the scenarios and every case's overrides validate and describe the thesis's plate; then a
coarse, short version of the reference-like case A/H = 0.3, D/H = 0.1 (l0 = H/12 = 0.0095 m: the
coarsest whole-layer spacing that still gives the 0.015 m plate two particle rows, one row has no
vertical normal; dt_max = 2 ms; run until 0.05 s after the design crest reaches the plate) for the
rigid plate (uplift peak against physical bounds) and the elastic plate (it couples and its
mid-span rises). The case definitions are validation/bottom_slamming.py's.

Slow (-m slow): the l0 = H/28 results of validation/bottom_slamming.py (read from its CSV; the
runs take 5-15 min each on one thread and are not started here).
"""

import csv
import tomllib
from pathlib import Path

import h5py
import numpy as np
import pytest
from validation_script import load

from mpsfem.scenario.loader import load_scenario
from mpsfem.simulation import run_coupled, run_fluid

ROOT = Path(__file__).resolve().parents[2]


bs = load("bottom_slamming")

H = bs.DEPTH
L0_COARSE = H / 12
CASE = bs.Case(0.3, 0.1)
END_TIME = CASE.crest_time + 0.05  # the design crest reaches the front edge at 1.953 s
#: the force on the dry plate before the wave, N/m: at D = 1.2 l0 above still water the plate's
#: particles are inside the fluid surface's viscous Laplacian (radius 4.01 l0), and the
#: default force model (fluid.boundary_force = "pressure_and_contact") reports that viscous
#: exchange: at most rho nu U L / l0 with U = 0.1 m/s, far above the still water's speeds
#: (measured up to 7e-5 N/m), and 1e-4 of the uplift's lower bound (35 N/m)
DRY_FORCE = bs.DENSITY * 1e-6 * 0.1 * bs.PLATE_LENGTH / L0_COARSE


def _coarse(kind: str):
    items = bs.case_overrides(kind, CASE, L0_COARSE) + [
        "fluid.time_step.dt_max=2e-3",  # Courant 0.2 l0 / u allows 1.9e-3 s at 1 m/s
        "output.snapshot_interval=0",
        "output.checkpoint_interval=0",
    ]
    if kind == "elastic":
        items.append("structure.time.dt=2e-3")  # = the coupling window = dt_max
    return load_scenario(bs.SCENARIOS[kind], items)


def test_uplift_impulse_of_a_half_sine_pulse():
    """The impulse of F = F0 sin(pi (t - t0) / T) over its duration is 2 F0 T / pi; sampled at
    1 ms (the probe interval) over T = 0.1 s the trapezoidal rule is within 1e-3 of it, samples
    before the contact and after the window's end are left out, no contact gives NaN."""
    t = np.arange(0.0, 1.0, 1e-3)
    t0, T, F0 = 0.3, 0.1, 200.0
    f = np.where((t >= t0) & (t <= t0 + T), F0 * np.sin(np.pi * (t - t0) / T), 0.0)
    f[t > 0.8] = 1e6  # after the window: must not count
    exact = 2.0 * F0 * T / np.pi
    assert bs.uplift_impulse(t, f, t0, 0.8) == pytest.approx(exact, rel=1e-3)
    assert np.isnan(bs.uplift_impulse(t, f, float("nan"), 0.8))


@pytest.fixture(scope="module")
def rigid_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("slam") / "rigid.h5"
    run_fluid(_coarse("rigid"), out, progress=False, end_time=END_TIME)
    return out


@pytest.fixture(scope="module")
def elastic_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("slam") / "elastic.h5"
    run_coupled(_coarse("elastic"), out, progress=False, end_time=END_TIME, log=lambda m: None)
    return out


def test_scenarios_describe_the_thesis_plate():
    """Both scenarios' default case is A/H = 0.3, D/H = 0.06 with the thesis's plate (0.305 m x
    0.015 m, front edge 1.2 m, bottom at H + D); the elastic member carries exactly the
    structure of scenarios/structure_bottom_slamming_2d.toml (material, damping, supports,
    section), and every one of the 24 cases' overrides gives a valid scenario with the plate
    at H (1 + D/H) and the paddle making A."""
    rigid = load_scenario(bs.SCENARIOS["rigid"]).scenario
    plate = rigid.fluid.walls[bs.PLATE_WALL]
    assert plate.name == "plate" and plate.shape == "box"
    assert plate.lower == pytest.approx([1.2, 1.06 * H])
    assert plate.upper == pytest.approx([1.505, 1.06 * H + 0.015])
    assert rigid.fluid.walls[bs.PADDLE_WALL].motion.amplitude == pytest.approx(0.3 * H)

    elastic = load_scenario(bs.SCENARIOS["elastic"]).scenario
    member = elastic.structure.members[0]
    assert member.start == pytest.approx([1.2, 1.06 * H + 0.0075])
    assert member.end == pytest.approx([1.505, 1.06 * H + 0.0075])
    with (ROOT / "scenarios" / "structure_bottom_slamming_2d.toml").open("rb") as f:
        ref = tomllib.load(f)["structure"]["members"][0]
    for key in ("bc", "thickness", "rayleigh_a1", "rayleigh_a2", "self_weight", "type"):
        assert getattr(member, key) == ref[key], key
    assert member.material.youngs_modulus == ref["material"]["youngs_modulus"]
    assert member.material.density == ref["material"]["density"]

    for case in bs.all_cases():
        for kind in bs.KINDS:
            sc = load_scenario(bs.SCENARIOS[kind], bs.case_overrides(kind, case, 0.004)).scenario
            bottom = (
                sc.fluid.walls[bs.PLATE_WALL].lower[1]
                if kind == "rigid"
                else sc.structure.members[0].start[1] - 0.0075
            )
            assert bottom == pytest.approx(H * (1.0 + case.clearance), abs=1e-12)
            assert sc.fluid.walls[bs.PADDLE_WALL].motion.amplitude == pytest.approx(case.ratio * H)
            assert sc.run.end_time == case.end_time(kind)
            assert case.end_time(kind) >= case.crest_time + bs.AFTER_CREST - 1e-3
    assert len(bs.all_cases()) == 12
    assert bs.elements_for(bs.spacing_for(0.002)) == 152  # thesis Table 5-1
    assert bs.elements_for(bs.spacing_for(0.0015)) == 203  # thesis Table 5-1


def test_reflection_stays_off_the_plate_in_the_peak_window():
    """The scenario header's timing: the 10 %-of-A foot of the wave sent back by the sponge's
    inner edge reaches the plate's rear edge 0.70 s (A/H = 0.2) to 0.82 s (0.5) after the crest
    reaches the front edge, later than the thesis's elastic peak (0.16 s after it); the elastic
    runs last that long, and the crest reaches the front edge at 1.953 s for A/H = 0.3 (thesis
    Fig. 5-7: 1.96 s)."""
    after = {r: bs.Case(r, 0.06).reflection_time - bs.Case(r, 0.06).crest_time for r in bs.RATIOS}
    assert after[0.2] == pytest.approx(0.697, abs=2e-3)
    assert after[0.3] == pytest.approx(0.769, abs=2e-3)
    assert after[0.5] == pytest.approx(0.824, abs=2e-3)
    assert min(after.values()) > bs.THESIS_TIMES["second_slam"] - bs.THESIS_TIMES["rigid_peak"]
    for r in bs.RATIOS:
        case = bs.Case(r, 0.06)
        assert case.end_time("elastic") >= case.reflection_time
    assert CASE.crest_time == pytest.approx(1.953, abs=1e-3)


def test_rigid_uplift_peak_between_physical_bounds(rigid_run):
    """The rigid plate feels nothing until the wave arrives, then an uplift whose 11 ms-mean
    peak lies between the quasi-static uplift with the crest at the front edge (35.0 N/m) and
    the largest quasi-static uplift plus a Wagner-type slamming part rho c w_max L (105.0 N/m):
    bs.uplift_bounds gives the reasoning. Measured at l0 = H/12: 48.6 N/m (raw peak 75.7 N/m:
    single-step pressure spikes, not bounded by this estimate)."""
    res = bs.analyse(rigid_run)
    assert res.status == "finished"
    with h5py.File(rigid_run, "r") as h5:
        t, f = h5["probes"]["uplift"]["time"][:], h5["probes"]["uplift"]["value"][:]
    dry = t < CASE.crest_time - 0.5  # the wave's foot (1 % of A) is 0.72 m ahead of the crest
    assert np.all(np.abs(f[dry]) < DRY_FORCE)
    lo, hi = bs.uplift_bounds(CASE)
    print(
        f"l0 = H/12: uplift peak {res.peak_uplift:.1f} N/m at t_c {res.peak_time_s - CASE.crest_time:+.3f} s, "
        f"11 ms mean {res.peak_uplift_smooth:.1f} N/m; bounds {lo:.1f} ... {hi:.1f} N/m"
    )
    assert lo <= res.peak_uplift_smooth <= hi


def test_elastic_plate_couples_and_rises(elastic_run):
    """The coupled plate stays at rest until the water reaches it, then its mid-span rises by
    more than a tenth of the static deflection 5 q L^4 / (384 E I) under its own 11 ms-mean
    peak uplift spread evenly (q = F / L): the load lasts a few tenths of a second against a
    wet first period of about a second (added mass of water ~ rho L / pi per unit area, six
    times the plate's 15.6 kg/m^2), so the dynamic response is a fraction of the static one,
    but not a small one. Measured at l0 = H/12: see the printout."""
    res = bs.analyse(elastic_run)
    assert res.status == "finished"
    with h5py.File(elastic_run, "r") as h5:
        td, u = h5["probes"]["plate_mid"]["time"][:], h5["probes"]["plate_mid"]["value"][:]
        tf, f = h5["probes"]["uplift"]["time"][:], h5["probes"]["uplift"]["value"][:]
        iterations = h5["coupling"]["iterations"][:]
    # at rest until the first touch of water (a force above the dry plate's viscous one; the
    # contact time of the analysis is when the uplift first exceeds 2 % of its peak, and a
    # touch just below that moves it): no more than the static deflection under DRY_FORCE
    first_touch = tf[np.flatnonzero(np.abs(f).max(axis=1) > DRY_FORCE)[0]]
    assert first_touch <= res.contact_time_s
    before = td < first_touch
    e, t = 1e6, 0.015
    rest = 5.0 * DRY_FORCE * bs.PLATE_LENGTH**3 / (384.0 * e * t**3 / 12.0)
    assert before.sum() > 100 and np.all(np.abs(u[before]) < rest)
    q = res.peak_uplift_smooth / bs.PLATE_LENGTH
    static = 5.0 * q * bs.PLATE_LENGTH**4 / (384.0 * e * t**3 / 12.0)
    print(
        f"l0 = H/12: mid-span up {res.mid_disp_max_mm:.2f} mm at t_c "
        f"{res.mid_disp_max_time_s - CASE.crest_time:+.3f} s; static under the 11 ms-mean peak "
        f"{res.peak_uplift_smooth:.1f} N/m: {static * 1e3:.1f} mm; iterations per window "
        f"{iterations.mean():.2f} (max {iterations.max()}), unconverged {res.unconverged_windows}"
    )
    assert res.mid_disp_max_mm > 0.1 * static * 1e3
    assert iterations.max() > 1  # the coupling iterated once the plate was loaded


def _csv_rows():
    path = bs.RESULTS_DIR / "bottom_slamming_0.004.csv"
    if not path.is_file():
        pytest.skip(f"{path} missing: run validation/bottom_slamming.py --l0 0.004 first")
    with path.open() as f:
        return {
            (r["kind"], float(r["a_over_h"]), float(r["d_over_h"])): r for r in csv.DictReader(f)
        }


@pytest.mark.slow
@pytest.mark.parametrize("case", bs.all_cases(), ids=lambda c: c.label())
def test_full_resolution_rigid_peak_between_physical_bounds(case):
    """l0 = H/28: the rigid plate's 11 ms-mean uplift peak within bs.uplift_bounds."""
    row = _csv_rows().get(("rigid", case.ratio, case.clearance))
    if row is None or row["status"] != "finished":
        pytest.skip(f"rigid {case.label()} not run to the end at l0 = 0.004")
    lo, hi = bs.uplift_bounds(case)
    peak = float(row["peak_uplift_smooth"])
    print(f"{case.label()}: 11 ms-mean peak {peak:.1f} N/m, bounds {lo:.1f} ... {hi:.1f}")
    assert lo <= peak <= hi


@pytest.mark.slow
@pytest.mark.parametrize("clearance", bs.CLEARANCES)
def test_full_resolution_elastic_plate_yields(clearance):
    """l0 = H/28, A/H = 0.3: the elastic plate (E = 1 MPa, 15.6 kg/m^2, simply supported; its
    section from the stated 0.015 m thickness) rises by more than a tenth of its static
    deflection under its own 11 ms-mean peak uplift (as the CI test), and its largest uplift
    stays below the rigid plate's (MF < 1): hydroelastic relief. Reasoning: with the added
    mass of the water under it (about rho / k_1 coth(k_1 H) = 117 kg/m^2, k_1 = pi / L) its
    first wet period is about 1.3 s (f = 2.27 Hz dry), long against the ~0.5 s of the rigid
    plate's uplift, so it cannot rebound into the wave while the crest passes; instead it
    rises at up to 0.1 m/s, nearly as fast as the water surface below it (c A k 4/(3 sqrt 3) =
    0.13 m/s), which takes away the relative velocity that makes the slamming pressure.

    This is NOT the thesis's result (MF = 3.23, 5.28, 3.66 at A/H = 0.3, from a "second slam"
    0.16 s after the first peak, which needs a plate period of about 0.3 s): the thesis's
    plate tables (A = 2.5e-5 m^2, I = 1e-3 m^4) contradict its thickness, and the section they
    suggest cannot be what it ran (docs/validation_bottom_slamming.md)."""
    rows = _csv_rows()
    rig, ela = rows.get(("rigid", 0.3, clearance)), rows.get(("elastic", 0.3, clearance))
    if rig is None or ela is None or not rig["status"] == ela["status"] == "finished":
        pytest.skip(f"A/H = 0.3, D/H = {clearance}: rigid and elastic not both run")
    mf = float(ela["peak_uplift"]) / float(rig["peak_uplift"])
    q = float(ela["peak_uplift_smooth"]) / bs.PLATE_LENGTH
    static = 5.0 * q * bs.PLATE_LENGTH**4 / (384.0 * 1e6 * 0.015**3 / 12.0)
    rise = float(ela["mid_disp_max_mm"]) * 1e-3
    print(
        f"A/H = 0.3, D/H = {clearance}: MF = {mf:.2f} (thesis {bs.THESIS_MF[(0.3, clearance)]}), "
        f"mid-span rise {rise * 1e3:.1f} mm, static {static * 1e3:.1f} mm"
    )
    assert rise > 0.1 * static
    assert 0.0 < mf < 1.0


@pytest.mark.slow
def test_resolution_study_elastic_rise_settles():
    """Thesis Table 5-1's spacings (l0 = 0.0025, 0.002, 0.0015 m; A/H = 0.3, D/H = 0.1; the
    committed CSVs of validation/bottom_slamming.py): the elastic plate's largest mid-span rise
    lies within 3 % of the three runs' mean, and MF stays below one at each.

    3 %: the rise integrates the load over the ~0.3 s of uplift, so the particle noise that
    spoils the peaks averages out, and what remains is the load's O(l0) error: the pressure is
    taken on a layer l0/2 inside the wetted face (thesis eq. 2-51), which put the 3D
    hydrostatic plate's load 2.7-4.0 % high at its spacings (docs/validation.md); 3 % allows an
    error of that order changing with l0, not a trend that would double it. Measured: 18.19,
    18.47, 18.89 mm (mean 18.52, spread -1.8 ... +2.0 %); the peak uplift (51.6, 47.8, 57.4 N/m) is not asserted, it scatters with the contact spike."""
    rises, mfs = [], []
    for label in ("0.0025", "0.002", "0.0015"):
        path = bs.RESULTS_DIR / f"bottom_slamming_{label}.csv"
        if not path.is_file():
            pytest.skip(f"{path} missing: validation/bottom_slamming.py --l0 {label}")
        with path.open() as f:
            rows = {r["kind"]: r for r in csv.DictReader(f)}
        if "elastic" not in rows or "rigid" not in rows:
            pytest.skip(f"l0 = {label}: rigid and elastic not both run")
        rises.append(float(rows["elastic"]["mid_disp_max_mm"]))
        mfs.append(float(rows["elastic"]["peak_uplift"]) / float(rows["rigid"]["peak_uplift"]))
    mean = float(np.mean(rises))
    print(f"mid-span rise {rises} mm (mean {mean:.2f}), MF {[round(m, 2) for m in mfs]}")
    assert all(abs(r / mean - 1.0) < 0.03 for r in rises)
    assert all(0.0 < m < 1.0 for m in mfs)
