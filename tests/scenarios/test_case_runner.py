"""validation/case_runner.py: what every study script shares before it starts a run."""

import argparse

import pytest
from validation_script import load

cr = load("case_runner")


def test_thread_count_accepts_whole_numbers_from_one():
    assert cr.thread_count("1") == 1
    assert cr.thread_count("2") == 2


@pytest.mark.parametrize("bad", ["0", "-1", "x", "1.5"])
def test_thread_count_refuses_with_the_key_and_the_allowed_values(bad):
    with pytest.raises(argparse.ArgumentTypeError, match=rf"--threads = '{bad}': must be a whole"):
        cr.thread_count(bad)
