"""Probes and snapshots are taken on a fixed grid k x interval (no drift), and a run writes its
final state at end_time."""

from pathlib import Path

import h5py
import numpy as np
import pytest

from mpsfem.sampling import is_due, next_due
from mpsfem.scenario.loader import load_scenario
from mpsfem.simulation import run_fluid

ROOT = Path(__file__).resolve().parents[2]


def test_next_due_is_the_next_grid_time():
    assert next_due(0.0, 0.002) == pytest.approx(0.002)
    assert next_due(0.0029, 0.002) == pytest.approx(0.004)  # a late sample keeps the grid
    assert next_due(0.004 - 1e-15, 0.002) == pytest.approx(0.006)  # round-off lands on 0.004
    assert next_due(0.37, 0.0) == 0.37  # every step
    assert is_due(0.004 - 1e-15, 0.004, 0.002)
    assert not is_due(0.0039, 0.004, 0.002)


def test_no_drift_and_final_state(tmp_path):
    # dt_max 1.5 ms against a 2 ms grid: 't_last + interval' scheduling drifts by the overshoot
    # of every sample (a sample every 3 ms here); the grid takes one per 2 ms slot
    loaded = load_scenario(
        ROOT / "scenarios" / "hydrostatic_2d.toml",
        [
            "fluid.spacing=0.02",
            "fluid.time_step.dt_max=1.5e-3",
            "fluid.time_step.dt_initial=1.5e-3",
            "output.probe_interval=0.002",
            "output.snapshot_interval=0.0125",
            "output.checkpoint_interval=0",
            "run.progress=false",
        ],
    )
    out = tmp_path / "h.h5"
    run_fluid(loaded, out, end_time=0.0505)
    with h5py.File(out, "r") as h5:
        t = h5["probes/gauge/time"][:]
        snaps = sorted(h5["particles"])
        t_snap = [h5["particles"][k].attrs["time"] for k in snaps]
    # one sample per grid slot [k 2 ms, (k + 1) 2 ms) reached by a step, plus the final state
    slots = np.floor(t[:-1] / 0.002 + 1e-9)
    assert len(np.unique(slots)) == len(slots)
    assert np.diff(t).max() <= 0.002 + 1.5e-3 + 1e-12  # a gap is at most interval + one step
    assert len(t) >= 0.05 / 0.002 * (1 - 1.5e-3 / 0.002) + 1
    assert t[-1] == pytest.approx(0.0505, abs=1e-12)  # the final state
    assert t_snap[-1] == pytest.approx(0.0505, abs=1e-12)
    # one snapshot per 12.5 ms slot (the step ending at 50.5 ms is both the 50 ms one and the end)
    assert np.floor(np.array(t_snap) / 0.0125 + 1e-9).tolist() == [0, 1, 2, 3, 4]
