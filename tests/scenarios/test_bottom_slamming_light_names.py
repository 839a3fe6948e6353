"""validation/bottom_slamming_light.py: every run's settings are recoverable from its file name
(the analysis reads them back from the name, so a setting the name loses is a mislabelled row)."""

import numpy as np
import pytest
from validation_script import load

bsl = load("bottom_slamming_light")


@pytest.mark.parametrize(
    "kw, expect",
    [
        ({}, {"pf": None, "corot": None, "acc": None, "maxit": None}),
        (
            {"model": "potential_flow", "wet_pressure": 3.0, "max_iterations": 100},
            {"pf": "_pf", "wp": "3", "maxit": "100", "corot": None},
        ),
        (
            {"model": "potential_flow", "kinematics": "corotational", "force_tolerance": "0.05"},
            {"pf": "_pf", "corot": "_corot", "ft": "0.05"},
        ),
        (
            {"acceleration": "iqn-imvj", "kinematics": "corotational", "end_time": 2.1},
            {"acc": "iqn-imvj", "corot": "_corot", "end": "2.1"},
        ),
        (
            {"model": "potential_flow", "end_time": 2.4, "branched_from": 2.1},
            {"pf": "_pf", "end": "2.4", "frm": "2.1"},
        ),
        ({"end_time": 2.1}, {"end": "2.1", "frm": None}),
        (
            {"kinematics": "corotational", "safeguards": True, "force_tolerance": "0.05"},
            {"corot": "_corot", "sg": "_sg", "ft": "0.05"},
        ),
        ({"kinematics": "corotational"}, {"corot": "_corot", "sg": None, "ramp": None}),
        (
            {"kinematics": "corotational", "safeguards": True, "collision_ramp": 0.1},
            {"corot": "_corot", "sg": "_sg", "ramp": "0.1"},
        ),
        ({"kinematics": "corotational"}, {"corot": "_corot", "mg": None}),
        (
            {"kinematics": "corotational", "wet_margin": 0, "force_tolerance": "0.05"},
            {"corot": "_corot", "mg": "0", "ft": "0.05"},
        ),
    ],
)
def test_run_path_names_parse_back_to_their_settings(kw, expect):
    case = bsl.Case(0.3, 0.06)
    path = bsl.run_path("0.0057", case, 0.35, 1e-3, **kw)
    m = bsl.NAME.match(path.name)
    assert m is not None, path.name
    assert m["mf"] == "0.35" and m["a"] == "0.30" and m["d"] == "0.06"
    for group, value in expect.items():
        assert m[group] == value, (group, path.name)


dsph = load("bottom_slamming_light_delta_sph")


@pytest.mark.parametrize("run", dsph.AITKEN_RUNS)
def test_delta_sph_aitken_names_parse_back_to_their_settings(run):
    """The δ-SPH study's Aitken runs: the MPS MF table's keys read back from the name (its report
    analyses them with NAME), the force tolerance of the "_ft01" tag, and each prefix tag in
    the name and, as its override, in the run's settings; no two runs share a file."""
    path = dsph.run_path(run, 2.73)
    m = bsl.NAME.search(path.name)
    assert m is not None, path.name
    assert (m["mf"], m["maxit"], m["pf"], m["wp"], m["corot"], m["sg"]) == (
        "0.35",
        "100",
        "_pf",
        "3",
        "_corot",
        "_sg",
    )
    assert m["ft"] == ("0.01" if run.endswith("_ft01") else "0.05")
    sets = dsph.overrides(run, 0.0057, 2.73)
    in_name = path.name.split("bottom_slamming_light")[0].removeprefix("dsph_wetted_").split("_")
    for tag, extra in dsph.PREFIX_TAGS.items():
        tagged = tag in run.split("_")
        assert (tag in in_name) is tagged, (tag, path.name)
        assert all(o in sets for o in extra) is tagged, (tag, sets)
    assert len({dsph.run_path(r, 2.73) for r in dsph.AITKEN_RUNS}) == len(dsph.AITKEN_RUNS)


def test_wet_split_starts_at_the_first_wet_set_away_from_dh_006():
    """D/H = 0.06 keeps the fixed WET_FROM of every earlier row; another clearance starts at the
    end of the first window with a finite fictitious force error (a nonempty wet set)."""
    t = np.arange(1, 11) * 0.1
    ferr = np.full(t.size, np.nan)
    ferr[6:] = 0.02  # wet from the window ending at 0.7 s
    assert bsl.wet_from(bsl.Case(0.3, 0.06), t, ferr) == bsl.WET_FROM
    assert bsl.wet_from(bsl.Case(0.3, 0.03), t, ferr) == pytest.approx(0.7)
    assert bsl.wet_from(bsl.Case(0.3, 0.1), t, ferr) == pytest.approx(0.7)
    assert np.isnan(bsl.wet_from(bsl.Case(0.3, 0.1), t, np.full(t.size, np.nan)))
    assert np.isnan(bsl.wet_from(bsl.Case(0.3, 0.1), t, None))
    assert np.isnan(bsl.wet_from(bsl.Case(0.3, 0.1), t, ferr[:-1]))  # misaligned column


@pytest.mark.parametrize(
    "d, kw, clearance, crest",
    [
        (0.03, {"end_time": 2.4}, True, False),
        (0.1, {"end_time": 2.1}, True, False),
        (0.06, {"end_time": 2.4}, True, True),
        (0.03, {"end_time": 1.5, "force_tolerance": "off"}, False, False),  # the dry base
        (0.06, {"end_time": 2.4, "branched_from": 2.1}, False, True),
    ],
)
def test_figure_groups_keep_other_clearances_out_of_the_dh_006_figures(d, kw, clearance, crest):
    kw = {"model": "potential_flow", "wet_pressure": 3.0, "kinematics": "corotational"} | kw
    path = bsl.run_path("0.0057", bsl.Case(0.3, d), 0.35, 1e-3, **kw)
    assert bsl._clearance_study(path) is clearance
    assert bsl._crest_study(path, with_base=True) is crest
    assert bsl._other_clearance(path) is (d != 0.06)


def test_rigid_reference_at_the_rows_own_spacing(tmp_path, monkeypatch):
    """MF at the same spacing reads bottom_slamming_<l0>.csv of the row's l0 label; NaN where
    that spacing has no rigid run of the case."""
    (tmp_path / "bottom_slamming_0.0057.csv").write_text(
        "kind,a_over_h,d_over_h,peak_uplift,peak_uplift_smooth\n"
        "rigid,0.3,0.06,91.0,67.6\nelastic,0.3,0.03,1.0,1.0\n"
    )
    monkeypatch.setattr(bsl, "RESULTS_DIR", tmp_path)
    assert bsl.rigid_reference(bsl.Case(0.3, 0.06), "0.0057") == (91.0, 67.6)
    assert all(np.isnan(bsl.rigid_reference(bsl.Case(0.3, 0.03), "0.0057")))
    assert all(np.isnan(bsl.rigid_reference(bsl.Case(0.3, 0.06), "0.004")))  # no such file


def test_return_load_is_the_load_after_the_mid_span_maximum(tmp_path):
    """A plate that rises to its largest displacement at 2.0 s and is back at rest at 2.3 s
    under a load with a first pulse at 1.8 s and a smaller second one at 2.25 s: the return
    peak is the second pulse (raw and in 11 ms means), at its time, and the rest time 2.3 s."""
    import h5py

    case = bsl.Case(0.3, 0.06)
    t = np.round(np.arange(0, 2601) * 1e-3, 9)
    fy = 50.0 * np.exp(-(((t - 1.8) / 0.01) ** 2)) + 20.0 * np.exp(-(((t - 2.25) / 0.01) ** 2))
    uy = np.clip(0.02 * np.sin(np.pi * (t - 1.7) / 0.6), 0.0, None) * (t >= 1.7)
    uy[t >= 2.3] = -1e-4
    path = tmp_path / "run.h5"
    with h5py.File(path, "w") as h5:
        for name, v in (("uplift", fy), ("plate_mid", uy)):
            g = h5.create_group(f"probes/{name}")
            g["time"] = t
            g["value"] = np.stack([np.zeros_like(v), v], axis=1)
    out = bsl.return_load(path, case)
    assert out["return_peak"] == pytest.approx(20.0, rel=1e-3)
    assert out["return_peak_time_s"] == pytest.approx(2.25)
    assert out["return_peak_smooth_time_s"] == pytest.approx(2.25)
    # the 11 ms mean (samples -5 ... 5 ms) of a Gaussian pulse of 1/e half-width 10 ms at its top
    mean = np.mean(np.exp(-((np.arange(-5, 6) / 10.0) ** 2)))  # 0.908
    assert out["return_peak_smooth"] == pytest.approx(20.0 * mean, rel=1e-3)
    assert out["mid_back_at_rest_s"] == pytest.approx(2.3)


def _table_row(a: float, d: float, t_end: float, **kw) -> dict:
    """A CSV row (strings, as read back) of the MF table's setting, overridable per key."""
    row = {
        "l0_label": "0.004", "a_over_h": str(a), "d_over_h": str(d), "t_end_s": str(t_end),
        "kinematics": "corotational", "fictitious_mass_model": "potential_flow",
        "mf_factor": "0.35", "wet_pressure_pa": "3.0", "force_tolerance": "0.05",
        "max_iterations": "100", "rtol": "0.001", "relative_to": "displacement",
        "acceleration": "aitken", "wet_update": "window", "freeze_surface": "False",
        "branched_from_s": "nan", "wet_from_s": "1.5", "wet_windows": "200",
        "wet_it_mean": "12.0", "wet_unconverged": "10", "interface_work_error_pct": "2.0",
        "peak_uplift": "5.0", "peak_time_s": "2.0", "peak_uplift_smooth": "2.0",
        "peak_smooth_time_s": "2.0", "rigid_peak_same_l0": "100.0",
        "rigid_peak_smooth_same_l0": "50.0", "mf_raw_same_l0": "0.05",
        "mf_smooth_same_l0": "0.04", "mid_disp_max_mm": "30.0", "mid_disp_max_time_s": "2.1",
        "mid_back_at_rest_s": "2.5", "return_peak_smooth": "1.0",
        "results_file": f"run_{a}_{d}_{t_end}.h5",
    }  # fmt: skip
    return row | {k: str(v) for k, v in kw.items()}


def test_mf_table_takes_each_cases_longest_run_of_its_setting(tmp_path, monkeypatch):
    """Per case the longest run of MF_TABLE_SETTING at MF_TABLE_L0 (another factor, spacing, a
    branch or a frozen-flags run is not the table's), with the heavy plate's MF against the
    rigid one from bottom_slamming_<l0>.csv and the thesis's MF."""
    (tmp_path / "bottom_slamming_0.004.csv").write_text(
        "kind,a_over_h,d_over_h,peak_uplift,peak_uplift_smooth\n"
        "rigid,0.2,0.06,200.0,50.0\nelastic,0.2,0.06,40.0,20.0\n"
    )
    monkeypatch.setattr(bsl, "RESULTS_DIR", tmp_path)
    rows = [
        _table_row(0.2, 0.06, 2.1),
        _table_row(0.2, 0.06, 2.9, wet_windows=100, wet_unconverged=5),
        _table_row(0.2, 0.06, 3.5, mf_factor=0.5),  # another factor
        _table_row(0.2, 0.06, 3.5, freeze_surface=True),  # frozen flags
        _table_row(0.2, 0.06, 3.5, branched_from_s=2.1),  # a branch
        _table_row(0.3, 0.03, 3.5, l0_label="0.0057"),  # another spacing
        _table_row(0.5, 0.1, 2.0),
    ]
    table = bsl.mf_table(rows)
    assert [(r["a_over_h"], r["d_over_h"]) for r in table] == [(0.2, 0.06), (0.5, 0.1)]
    first = table[0]
    assert first["t_end_s"] == 2.9 and first["results_file"] == "run_0.2_0.06_2.9.h5"
    assert first["wet_unconverged_pct"] == pytest.approx(5.0)
    assert (first["heavy_mf_raw"], first["heavy_mf_smooth"]) == (0.2, 0.4)
    assert first["thesis_mf"] == bsl.THESIS_MF[(0.2, 0.06)]
    assert first["reached_window_end"] is (2.9 >= bsl.Case(0.2, 0.06).reflection_time - 1e-3)
    assert np.isnan(table[1]["heavy_mf_raw"])  # no heavy run of that case in the CSV
    assert table[1]["reached_window_end"] is False  # 2.0 s is before its window's end


def test_mf_table_takes_the_safeguards_run_only_where_the_plain_one_stopped_short(
    tmp_path, monkeypatch
):
    """A case whose run of the table's setting stopped before the window's end (or was not run)
    is taken from the same setting with --safeguards if that got further, flagged; a case whose
    plain run reached the end keeps it even beside a longer safeguards run."""
    monkeypatch.setattr(bsl, "RESULTS_DIR", tmp_path)
    end = {k: bsl.Case(*k).reflection_time for k in ((0.5, 0.06), (0.5, 0.03), (0.2, 0.1))}
    rows = [
        _table_row(0.5, 0.06, 1.74),  # stopped by name before the window's end
        _table_row(0.5, 0.06, 2.5, safeguards=True),
        _table_row(0.5, 0.03, 2.5, safeguards=True),  # no plain run
        _table_row(0.2, 0.1, end[(0.2, 0.1)] + 0.1),  # reached the end
        _table_row(0.2, 0.1, end[(0.2, 0.1)] + 0.5, safeguards=True),
        _table_row(0.5, 0.1, 1.7),  # stopped, and its safeguards run stopped sooner
        _table_row(0.5, 0.1, 1.5, safeguards=True),
    ]
    table = {(r["a_over_h"], r["d_over_h"]): r for r in bsl.mf_table(rows)}
    assert table[(0.5, 0.06)]["safeguards"] and table[(0.5, 0.06)]["t_end_s"] == 2.5
    assert table[(0.5, 0.03)]["safeguards"]
    assert not table[(0.2, 0.1)]["safeguards"]
    assert not table[(0.5, 0.1)]["safeguards"] and table[(0.5, 0.1)]["t_end_s"] == 1.7


@pytest.mark.parametrize("a", [0.2, 0.4, 0.5])
def test_other_amplitudes_stay_out_of_the_a03_figures(a):
    """The MF table's runs at other amplitudes are in neither the A/H = 0.3 clearances figure
    nor the D/H = 0.06 study figures, and their wet windows start at their own first wet set."""
    kw = {"model": "potential_flow", "wet_pressure": 3.0, "kinematics": "corotational"}
    path = bsl.run_path("0.004", bsl.Case(a, 0.06), 0.35, 1e-3, end_time=2.5, **kw)
    assert not bsl._clearance_study(path)
    assert not bsl._crest_study(path, with_base=True)
    assert bsl._other_case(path)
    t = np.arange(1, 11) * 0.1
    ferr = np.where(t > 0.75, 0.02, np.nan)
    assert bsl.wet_from(bsl.Case(a, 0.06), t, ferr) == pytest.approx(0.8)


def test_static_capacity_is_the_linear_beam_then_the_pinned_string():
    """The light plate at rest under a uniform uplift: at 1e-4 N/m (3.7e-5 m, far below the
    section's radius of gyration sqrt(I / A) = 6.3 mm) the linear simply supported beam 5 q L^4 /
    (384 EI) within 1e-3 (the nodal lumping of the line load, O(h^2) at 74 elements); at 1 N/m
    (about 37 mm, six radii of gyration) the pinned string (3 q L^4 / (64 EA))^(1/3) within 5 %:
    the bending stiffness 384 EI / (5 L^4) is a tenth of the string's secant stiffness there
    (w ~ q^(1/3): at most 3.4 %), and the string's shallow-sag stretch (8 / 3) w^2 / L
    overestimates the stretch by (12 / 5) (w / L)^2 = 3.6 % (1.2 % in w)."""
    low, high = bsl.static_capacity((1e-4, 1.0))
    assert low["mid_disp_mm"] == pytest.approx(low["linear_beam_mm"], rel=1e-3)
    assert high["mid_disp_mm"] == pytest.approx(high["string_mm"], rel=0.05)
    assert high["mid_disp_mm"] < 0.2 * high["linear_beam_mm"]  # held by its membrane force
    assert 0.03 < high["max_axial_strain"] < 0.05  # (8 / 3) (w / L)^2 = 0.040


def test_safeguards_are_keys_the_scenario_takes():
    """--safeguards sets the obstacle's three keys (best iterate, retreating predictor, HHT
    -0.3) and the scenario loads with them (a misspelt key would be refused by name)."""
    from mpsfem.scenario.loader import load_scenario

    case = bsl.Case(0.5, 0.06)
    overrides = bsl.case_overrides("elastic", case, 0.004) + bsl.light_overrides(
        0.35, 1e-3, max_iterations=100, force_tolerance="0.05", model="potential_flow",
        wet_pressure=3.0, kinematics="corotational", safeguards=True,
    )  # fmt: skip
    sc = load_scenario(bsl.SCENARIOS["elastic"], overrides).scenario
    assert sc.coupling.convergence.accept_unconverged == "best"
    assert sc.coupling.convergence.retreat_predictor is True
    assert sc.structure.time.scheme == "hht"
    assert sc.structure.time.hht_alpha == bsl.SAFEGUARD_HHT_ALPHA
    plain = bsl.light_overrides(0.35, 1e-3, kinematics="corotational")
    assert not any("hht" in o or "accept_unconverged" in o for o in plain)


def test_csv_lock_excludes_a_second_writer(tmp_path, monkeypatch):
    """While one report merges into the CSV, another cannot take the lock (the lost update of
    two runs finishing at once); once released it can."""
    import fcntl

    monkeypatch.setattr(bsl, "CSV", tmp_path / "light.csv")
    lock = tmp_path / "light.csv.lock"
    with bsl._csv_lock():
        with open(lock, "w") as other, pytest.raises(BlockingIOError):
            fcntl.flock(other, fcntl.LOCK_EX | fcntl.LOCK_NB)
    with open(lock, "w") as other:
        fcntl.flock(other, fcntl.LOCK_EX | fcntl.LOCK_NB)  # free again


def test_delta_sph_wet_windows_start_with_the_crest():
    """validation/bottom_slamming_light_delta_sph.py --amplitude: the wet windows of A/H = 0.3
    start at the MPS runs' first contact (1.62 s, as before the option), those of the other
    amplitudes by the design crest's arrival as much earlier or later (a higher wave is
    faster); the A/H of a stored row is read back from its results file's case label."""
    starts = [dsph.wet_from(dsph.Case(a, 0.06)) for a in (0.2, 0.3, 0.4, 0.5)]
    assert starts[1] == dsph.WET_FROM == 1.62
    assert starts == sorted(starts, reverse=True)
    for a, t in zip((0.2, 0.4, 0.5), (starts[0], starts[2], starts[3]), strict=True):
        shift = dsph.Case(a, 0.06).crest_time - dsph.Case(0.3, 0.06).crest_time
        assert t - 1.62 == pytest.approx(shift, abs=1e-12)
    name = dsph.run_path("ait_corot_sg_floor20", 2.5).name.replace("AH0.30", "AH0.50")
    assert dsph.amplitude_of(name) == 0.5
