"""δ-SPH through the run loop: results file, probes, checkpoint and a bit-identical restart."""

from __future__ import annotations

import shutil

import h5py
import numpy as np

import mpsfem.simulation as simulation
from mpsfem.scenario.loader import load_scenario_text
from mpsfem.simulation import run_fluid

SCENE = """
[run]
end_time = 0.02
[output]
probe_interval = 0.002
snapshot_interval = 0.01
checkpoint_interval = 0.01
[fluid]
method = "delta-sph"
spacing = 0.02
[fluid.sph]
gradient = "corrected"
[[fluid.blocks]]
lower = [0.0, 0.0]
upper = [0.2, 0.3]
[[fluid.walls]]
name = "tank"
shape = "tank"
lower = [0.0, 0.0]
upper = [0.6, 0.5]
[[probes]]
name = "front"
kind = "front"
axis = 0
[[probes]]
name = "p_floor"
kind = "pressure"
position = [0.1, 0.01]
radius = 0.015
[[probes]]
name = "tank_force"
kind = "force"
target = "tank"
"""


def _probes(path):
    with h5py.File(path, "r") as h5:
        assert h5.attrs["status"] == "finished"
        return {k: (h5[f"probes/{k}/time"][:], h5[f"probes/{k}/value"][:]) for k in h5["probes"]}


def test_a_restart_continues_bit_for_bit(tmp_path, monkeypatch):
    """The interval checkpoint at t = 0.01 s (kept aside when written) resumes the run; its
    probes then equal the uninterrupted run's, bit for bit."""
    quiet = {"progress": False, "log": lambda msg: None}
    loaded = load_scenario_text(SCENE)
    write = simulation.write_checkpoint
    kept = []

    def keep_first(path, *args, **kwargs):
        out = write(path, *args, **kwargs)
        if not kept:
            kept.append(shutil.copy(out, tmp_path / "mid.ckpt.h5"))
        return out

    monkeypatch.setattr(simulation, "write_checkpoint", keep_first)
    run_fluid(loaded, tmp_path / "full.h5", **quiet)
    monkeypatch.setattr(simulation, "write_checkpoint", write)
    shutil.copy(tmp_path / "full.h5", tmp_path / "part.h5")
    run_fluid(loaded, tmp_path / "part.h5", restart=tmp_path / "mid.ckpt.h5", **quiet)
    full, part = _probes(tmp_path / "full.h5"), _probes(tmp_path / "part.h5")
    assert set(full) == {"front", "p_floor", "tank_force"}
    for k, (t, v) in full.items():
        assert np.array_equal(t, part[k][0]), k
        assert np.array_equal(v, part[k][1]), k
    # the column has started to fall: its front moved right of the block's 0.2 m edge
    assert full["front"][1][-1] > 0.2
