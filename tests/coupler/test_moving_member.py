"""A coupled member with prescribed support motion carries the fluid's structure particles.

The structure participant reports absolute displacement and velocity ([structure.members.motion],
docs/structure.md "Support motion"); the fluid's structure particles (kind 3 and 4) must then
sit at reference + rigid translation and move at the prescribed velocity. The member moves in
air, so the elastic part stays zero and both checks are exact up to round-off.
"""

from __future__ import annotations

import h5py
import numpy as np

from mpsfem.scenario.loader import load_scenario
from mpsfem.simulation import run_coupled

SCENE = """
title = "member falling at constant speed above still water"
[run]
end_time = 0.004
threads = 1
[output]
probe_interval = 0
snapshot_interval = 0.002
[fluid]
dim = 2
spacing = 0.05
[[fluid.blocks]]
lower = [-0.5, 0.0]
upper = [0.5, 0.25]
[[fluid.walls]]
name = "tank"
shape = "tank"
lower = [-0.5, 0.0]
upper = [0.5, 0.75]
[structure]
record_interval = 0
[structure.time]
dt = 1e-3
[[structure.members]]
name = "plate"
type = "beam"
start = [-0.2, 0.55]
end = [0.2, 0.55]
elements = 8
bc = "clamped"
thickness = 0.05
[structure.members.material]
youngs_modulus = 2.1e11
density = 7800.0
[structure.members.motion]
kind = "constant_velocity"
direction = [0.0, -1.0]
velocity = 5.0
[coupling]
scheme = "implicit"
"""

V = 5.0


def test_structure_particles_follow_the_prescribed_motion(tmp_path):
    path = tmp_path / "moving.toml"
    path.write_text(SCENE)
    out = tmp_path / "moving.h5"
    run_coupled(load_scenario(path), out, progress=False, log=lambda m: None)
    with h5py.File(out, "r") as h5:
        snaps = sorted(h5["particles"])
        first, last = h5["particles"][snaps[0]], h5["particles"][snaps[-1]]
        t = float(last.attrs["time"])
        kind = last["kind"][()]
        sel = (kind == 3) | (kind == 4)
        p0, p1, v1 = first["pos"][()][sel], last["pos"][()][sel], last["vel"][()][sel]
        d = h5["structure/plate/displacement"][()]
        ts = h5["structure/plate/time"][()]
    assert t > 0.0 and sel.sum() > 0
    np.testing.assert_allclose(p1[:, 1] - p0[:, 1], -V * t, rtol=0, atol=1e-12)
    np.testing.assert_allclose(p1[:, 0], p0[:, 0], rtol=0, atol=1e-12)
    np.testing.assert_allclose(v1, np.tile([0.0, -V], (len(v1), 1)), rtol=0, atol=1e-12)
    # the records are absolute: every node moved by -V t
    np.testing.assert_allclose(d[:, :, 1], -V * ts[:, None] * np.ones(d.shape[1]), atol=1e-12)
