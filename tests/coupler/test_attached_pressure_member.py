"""A pressure probe attached to a coupled structure member rides with it (``attach``).

Case: a vertical post (a clamped beam, 0.04 m thick) sliding down along itself at 0.2 m/s
through still water 0.3 m deep (l0 = 0.02 m), its supports prescribed
([structure.members.motion]): the water stays hydrostatic along the faces, so a probe on a face
at reference height y0 reads rho g (H - y0 + V t). Tolerance rho g l0 for 0.025 s means, as in
tests/fluid_mps/test_attached_pressure_probe.py (the face rows slide past the fluid's lattice
rows; measured up to 0.4 rho g l0)."""

from __future__ import annotations

import shutil
from pathlib import Path

import h5py
import numpy as np
import pytest

from mpsfem.scenario.loader import load_scenario
from mpsfem.simulation import run_coupled

RHO, G, H, L0, V, Y0 = 1000.0, 9.81, 0.3, 0.02, 0.2, 0.2

SCENE = """
title = "a vertical post sliding down along itself in still water"
[run]
end_time = 0.2
threads = 1
progress = false
[output]
probe_interval = 0
snapshot_interval = 0
checkpoint_interval = 0
[fluid]
dim = 2
spacing = 0.02
hydrostatic_start = true
gravity = [0.0, -9.81]
[fluid.time_step]
courant = 0.2
dt_max = 1e-3
[[fluid.blocks]]
lower = [-0.2, 0.0]
upper = [0.2, 0.3]
[[fluid.walls]]
name = "tank"
shape = "tank"
lower = [-0.2, 0.0]
upper = [0.2, 0.5]
[structure]
record_interval = 0
[structure.time]
dt = 1e-3
[[structure.members]]
name = "post"
type = "beam"
start = [0.0, 0.1]
end = [0.0, 0.44]
elements = 17
bc = "clamped"
thickness = 0.04
self_weight = false
[structure.members.material]
youngs_modulus = 2.1e11
density = 7800.0
[structure.members.motion]
kind = "constant_velocity"
direction = [0.0, -1.0]
velocity = 0.2
[coupling]
scheme = "implicit"
[[probes]]
name = "riding"
kind = "pressure"
attach = "post+"
position = [-0.02, 0.2]
radius = 0.03
"""


def test_probe_on_a_moving_member_reads_the_hydrostatic_pressure_at_its_depth(tmp_path):
    path = tmp_path / "post.toml"
    path.write_text(SCENE)
    out = tmp_path / "post.h5"
    run_coupled(load_scenario(path), out, progress=False, log=lambda m: None)
    with h5py.File(out, "r") as h5:
        t = h5["probes/riding/time"][()]
        p = h5["probes/riding/value"][()]
        assert h5["probes/riding"].attrs["attach"] == "post+"
    expected = RHO * G * (H - Y0 + V * t)
    assert abs(p[0] - RHO * G * (H - Y0)) < 1e-9  # the hydrostatic start on the face
    errors = []
    for a in np.arange(0.0, 0.2, 0.025):
        s = (t >= a) & (t < a + 0.025)
        errors.append(np.mean(p[s] - expected[s]) / (RHO * G * L0))
    assert np.max(np.abs(errors)) < 1.0, np.round(errors, 3)
    # it went down with the post: two spacings deeper by the end
    assert np.mean(p[t > 0.175]) - p[0] > 1.5 * RHO * G * L0


PLATE = Path(__file__).resolve().parents[2] / "scenarios" / "hydrostatic_plate_2d.toml"
WINDOW = 2e-4
PLATE_PROBES = """
[[probes]]
name = "coarse"
kind = "pressure"
attach = "plate"
position = [0.5, 0.0]
radius = 0.05
interval = 0.0006
[[probes]]
name = "every_window"
kind = "pressure"
attach = "plate"
position = [0.5, 0.0]
radius = 0.05
interval = 0
average = false
"""


def test_averaged_probe_under_implicit_coupling_and_restart(tmp_path, monkeypatch):
    """The hydrostatic plate (scenarios/hydrostatic_plate_2d.toml, l0 = 0.05 m, implicit
    coupling, IQN-ILS; one fluid step per 0.2 ms window): the coarse averaged probe's samples
    times their intervals sum to the every-window instantaneous impulse (1e-12 relative: the
    iterations' restores roll the ledger back, else it would count each repeated step again);
    a restart from the checkpoint of window 4, between the coarse samples at windows 3 and 6,
    continues bit for bit."""
    from mpsfem import simulation
    from mpsfem.results.checkpoint import read_checkpoint

    write = simulation.write_checkpoint
    kept: list[Path] = []

    def keep(path, *args, **kwargs):
        out = write(path, *args, **kwargs)
        kept.append(tmp_path / f"kept{len(kept)}.ckpt.h5")
        shutil.copy(out, kept[-1])
        return out

    monkeypatch.setattr(simulation, "write_checkpoint", keep)
    path = tmp_path / "plate.toml"
    path.write_text(PLATE.read_text() + PLATE_PROBES)
    sets = [
        "fluid.spacing=0.05",
        "run.threads=1",
        "output.snapshot_interval=0",
        "output.checkpoint_interval=0.0008",
        "output.probe_interval=0",
        "structure.record_interval=0",
    ]
    full, part = tmp_path / "full.h5", tmp_path / "part.h5"
    run_coupled(load_scenario(path, sets), full, 10 * WINDOW, progress=False, log=lambda m: None)
    with h5py.File(full, "r") as h5:
        assert h5["coupling/iterations"][()].max() > 1  # restores happened
        steps = int(h5.attrs["steps"])
        tc, pc = h5["probes/coarse/time"][()], h5["probes/coarse/value"][()]
        tn, pn = h5["probes/every_window/time"][()], h5["probes/every_window/value"][()]
    assert steps == 10 and len(tc) == 5 and len(tn) == 11  # t = 0, 3, 6, 9, 10 windows
    assert np.sum(np.diff(tc) * pc[1:]) == pytest.approx(np.sum(np.diff(tn) * pn[1:]), rel=1e-12)
    ckpt = next(k for k in kept if read_checkpoint(k)[1]["scheme"]["index"] == 4)
    shutil.copy(full, part)
    run_coupled(load_scenario(path, sets), part, 10 * WINDOW, ckpt, progress=False, log=print)
    with h5py.File(full, "r") as a, h5py.File(part, "r") as b:
        for name in ("coarse", "every_window"):
            for key in ("time", "value"):
                ds = f"probes/{name}/{key}"
                assert a[ds][()].tobytes() == b[ds][()].tobytes(), ds
