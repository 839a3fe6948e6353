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
