"""validation/case_runner.py: what every study script shares before it starts a run."""

import argparse

import h5py
import numpy as np
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


def test_physics_branch_continues_a_finished_run_under_a_changed_physics_key(tmp_path, capfd):
    """A restart refuses a changed physics key; ``physics_branch`` continues the same state
    under it, logs the change, and the branch's record carries the base's history."""
    from mpsfem.cli import main as mpsfem_main

    scenario = cr.ROOT / "scenarios" / "hydrostatic_2d.toml"
    common = ["fluid.spacing=0.05", "output.snapshot_interval=0"]
    base = tmp_path / "base.h5"
    args = ["run", str(scenario), "--out", str(base), "--no-progress"]
    for item in [*common, "run.end_time=0.01", "output.checkpoint_interval=0.01"]:
        args += ["--set", item]
    assert mpsfem_main(args) == 0
    assert cr.read_status(base) == "finished"
    branch = [*common, "run.end_time=0.02", "fluid.viscosity=2e-6"]
    ckpt = cr.default_checkpoint_path(base)
    refused = cr.run_scenario(scenario, tmp_path / "plain.h5", branch, 1, ckpt)
    assert refused != 0  # the ordinary restart refuses the new viscosity
    out = tmp_path / "branch.h5"
    assert cr.physics_branch(scenario, base, out, branch, 1, retry=False) == "finished"
    cap = capfd.readouterr()
    assert "physics branch: fluid.viscosity: checkpoint 1e-06, now 2e-06" in cap.out + cap.err
    with h5py.File(base) as a, h5py.File(out) as b:
        t0 = a["probes"][next(iter(a["probes"]))]["time"][:]
        t1 = b["probes"][next(iter(b["probes"]))]["time"][:]
    assert t1[-1] == pytest.approx(0.02) and t0[-1] == pytest.approx(0.01)
    assert np.array_equal(t1[: t0.size], t0)  # the base's record, then the branch's


def test_a_branch_whose_restart_is_refused_is_resumed_not_skipped(tmp_path):
    """branch_case copies the base and restarts the copy; when that restart is refused before
    compute, the copy must not read ``finished`` (at the base's end time): a rerun resumes it."""
    scenario = cr.ROOT / "scenarios" / "hydrostatic_2d.toml"
    common = ["fluid.spacing=0.05", "output.snapshot_interval=0"]
    base = tmp_path / "base.h5"
    base_sets = [*common, "run.end_time=0.01", "output.checkpoint_interval=0.01"]
    out = tmp_path / "branch.h5"
    refused = [*common, "run.end_time=0.02", "fluid.viscosity=2e-6"]  # a physics key
    cr.branch_case(scenario, base, base_sets, out, refused, 0.01, 1, retry=False)
    assert cr.read_status(base) == "finished"
    assert cr.read_status(out) == "running" and cr.resumable(cr.read_status(out))
    ok = [*common, "run.end_time=0.02"]
    assert cr.ensure_case(scenario, out, ok, 1, retry=False) == "finished"
    with h5py.File(out) as h5:
        t = h5["probes"][next(iter(h5["probes"]))]["time"][:]
    assert t[-1] == pytest.approx(0.02)


def test_readable_results_yields_readable_files_and_skips_checkpoints(tmp_path, capsys):
    done, ckpt, gone = tmp_path / "a.h5", tmp_path / "a.ckpt.h5", tmp_path / "b.h5"
    for path in (done, ckpt):
        with h5py.File(path, "w") as h5:
            h5.attrs["status"] = "finished"
    broken = tmp_path / "c.h5"
    broken.write_bytes(b"not an hdf5 file")
    got = list(cr.readable_results([done, ckpt, gone, broken]))
    assert got == [(done, "finished")]
    out = capsys.readouterr().out
    assert "b.h5: None, skipped" in out and "c.h5: unreadable" in out
    assert cr.analysable("running") and not cr.analysable("locked")
