"""validation/bottom_slamming_light.py: every run's settings are recoverable from its file name
(the analysis reads them back from the name, so a setting the name loses is a mislabelled row)."""

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
