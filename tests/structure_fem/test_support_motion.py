"""Members whose supports follow a prescribed rigid translation ([structure.members.motion]).

The member is solved in its moving frame under the inertial load -rho A a_frame (per unit width),
and reports absolute displacement and velocity (docs/structure.md, "Support motion").
"""

import math
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np
import pytest
import structure_cases as sc
from pydantic import ValidationError

from mpsfem.scenario.motion import MemberMotion, RigidTranslation
from mpsfem.structure_fem.participant import StructureParticipant

E, RHO, T, L = 2.1e11, 7800.0, 0.01, 0.4
I_ = T**3 / 12.0  # second moment per unit width, m^3


def beam(n=20, bc="simply_supported", motion=None, **kw):
    m = {
        "name": "plate",
        "type": "beam",
        "start": [0.0, 0.0],
        "end": [L, 0.0],
        "elements": n,
        "bc": bc,
        "material": {"youngs_modulus": E, "poisson_ratio": 0.3, "density": RHO},
        "thickness": T,
    }
    if motion is not None:
        m["motion"] = motion
    m.update(kw)
    return m


def test_constant_velocity_moves_rigidly_without_deflection():
    V = -6.28
    part = StructureParticipant(
        sc.section([beam(motion={"kind": "constant_velocity", "direction": [0, 1], "velocity": V})])
    )
    for _ in range(50):
        part.advance(1e-4)
    t = part.time
    d = part.read("displacement")
    v = part.read("velocity")
    # rigid part exact; the elastic part is untouched (no frame acceleration, no load)
    np.testing.assert_allclose(d[:, 1], V * t, rtol=0, atol=1e-15)
    np.testing.assert_array_equal(d[:, 0], 0.0)
    np.testing.assert_allclose(v[:, 1], V, rtol=0, atol=1e-15)
    assert not part.integrator.state.u.any()
    assert part.energy() == (0.0, 0.0)  # energies are those relative to the frame


def test_constant_acceleration_gives_the_static_body_load_deflection(tmp_path):
    """Table s = a t^2 / 2 on the step grid: a constant frame acceleration a (up); with strong
    damping the elastic mid-span deflection settles on the simply supported beam's static
    deflection under q = -rho t a, w = 5 q L^4 / (384 E I). Hermite elements are nodally exact for
    a uniform load, so the error is what is left of the damped start-up transient: after 30 ms
    (about 7 of its e-folding times 1 / (zeta omega_1)) 3e-9 measured; tolerance 1e-6."""
    a, dt, n_steps = 50.0, 2e-5, 1500
    ts = np.arange(n_steps + 2) * dt
    pts = [[float(t), float(0.5 * a * t * t)] for t in ts]
    # first bending mode omega_1 = (pi / L)^2 sqrt(E I / (rho t)); a1 = 2 zeta omega_1, zeta ~ 1
    w1 = (math.pi / L) ** 2 * math.sqrt(E * I_ / (RHO * T))
    part = StructureParticipant(
        sc.section(
            [
                beam(
                    motion={"kind": "table", "direction": [0, 1], "points": pts},
                    rayleigh_a1=2.0 * w1,
                )
            ],
            time={"dt": dt},
        ),
        probes=[_Probe("mid", "plate", [L / 2, 0.0])],
    )
    for _ in range(n_steps):
        part.advance(dt)
    q = -RHO * T * a  # line load per unit width, N/m (up = +y = the beam's normal)
    w_static = 5.0 * q * L**4 / (384.0 * E * I_)  # Euler-Bernoulli, simply supported
    mid = part.probe_values()["mid"][1] - part.rigid_displacement("plate")[1]
    assert mid == pytest.approx(w_static, rel=1e-6)
    # absolute = rigid + elastic, the rigid part the table's s(t)
    s = float(np.interp(part.time, ts, [p[1] for p in pts]))
    assert part.read("displacement")[0, 1] == pytest.approx(s, rel=1e-12)


def test_harmonic_motion_equals_the_equivalent_pressure_load():
    """Dynamic response: the elastic part under harmonic support motion s = A sin(w t) equals the
    fixed member's response to the uniform pressure -rho t s''(t) = rho t A w^2 sin(w t)
    (the structure's own `pressure` load with a harmonic time function), to round-off."""
    A, f = 1e-3, 200.0
    w = 2.0 * math.pi * f
    dt, n = 1e-5, 400
    moving = StructureParticipant(
        sc.section(
            [
                beam(
                    motion={
                        "kind": "harmonic",
                        "direction": [0, 1],
                        "amplitude": A,
                        "period": 1 / f,
                    }
                )
            ],
            time={"dt": dt},
        )
    )
    fixed = StructureParticipant(
        sc.section(
            [beam()],
            time={"dt": dt},
            loads=[
                {
                    "kind": "pressure",
                    "member": "plate",
                    "value": RHO * T * A * w * w,
                    "time": {"kind": "harmonic", "frequency": f},
                }
            ],
        ),
        prescribed_loads=True,
    )
    for _ in range(n):
        moving.advance(dt)
        fixed.advance(dt)
    ue, uf = moving.integrator.state.u, fixed.integrator.state.u
    assert np.abs(uf).max() > 1e-7  # a response worth comparing
    np.testing.assert_allclose(ue, uf, rtol=0, atol=1e-9 * np.abs(uf).max())
    rigid = A * math.sin(w * moving.time)
    np.testing.assert_allclose(
        moving.read("displacement")[:, 1], fixed.read("displacement")[:, 1] + rigid, atol=1e-15
    )
    np.testing.assert_allclose(
        moving.read("velocity")[:, 1],
        fixed.read("velocity")[:, 1] + A * w * math.cos(w * moving.time),
        atol=1e-12,
    )


def test_checkpoint_restore_repeats_a_moving_member():
    part = StructureParticipant(
        sc.section(
            [
                beam(
                    motion={
                        "kind": "harmonic",
                        "direction": [0, 1],
                        "amplitude": 1e-3,
                        "period": 5e-3,
                    }
                )
            ]
        )
    )
    part.advance(1e-4)
    part.checkpoint()
    part.advance(3e-4)
    d1 = part.read("displacement").copy()
    part.restore()
    part.advance(3e-4)
    np.testing.assert_array_equal(part.read("displacement"), d1)


def test_plate_member_moves_along_its_normal():
    plate = dict(
        sc.PLATE, motion={"kind": "constant_velocity", "direction": [0, 0, -1], "velocity": 2.0}
    )
    part = StructureParticipant(sc.section([plate]))
    part.advance(1e-3)
    np.testing.assert_allclose(part.read("displacement")[:, 2], -2e-3, atol=1e-15)


class _Probe:
    def __init__(self, name, target, position):
        self.name, self.target, self.position = name, target, position


# --------------------------------------------------------------------------- law
def test_table_law_velocity_and_step_acceleration():
    law = RigidTranslation(
        MemberMotion(kind="table", points=[[0.0, 0.0], [1.0, 1.0], [2.0, 1.0]]), dim=2
    )
    assert law.scalar(0.5) == (0.5, 1.0)
    assert law.scalar(1.0) == (1.0, 1.0)  # at a knot: the segment ending there
    assert law.scalar(1.5) == (1.0, 0.0)
    assert law.step_acceleration(1.5, 1.0) == -1.0  # the jump at t = 1 within (0.5, 1.5]
    assert law.scalar(3.0) == (1.0, 0.0)  # held after the last row


def test_harmonic_law_starts_at_zero():
    law = RigidTranslation(
        MemberMotion(kind="harmonic", amplitude=0.1, period=2.0, phase=0.3, direction=[0, 2]), 2
    )
    assert law.displacement(0.0) == pytest.approx([0.0, 0.0], abs=1e-17)
    assert law.velocity(0.0)[1] == pytest.approx(0.1 * math.pi * math.cos(0.3))


# --------------------------------------------------------------------------- schema errors
@pytest.mark.parametrize(
    ("motion", "needle"),
    [
        ({"kind": "constant_velocity", "amplitude": 1.0}, "motion.amplitude is not used"),
        ({"kind": "table"}, "needs exactly one of motion.file"),
        ({"kind": "table", "points": [[0, 0], [0, 1]]}, "times must increase"),
        ({"kind": "table", "points": [[0, 0]]}, "at least two"),
        ({"kind": "harmonic", "period": 0.0}, "period"),
        ({"kind": "constant_velocity", "velocity": 2e3}, "velocity"),
        ({"kind": "constant_velocity", "direction": [0, 0]}, "zero vector"),
        ({"kind": "none", "velocity": 1.0}, "not used by kind = 'none'"),
        ({"kind": "spin"}, "kind"),
    ],
)
def test_motion_schema_errors_name_the_key(motion, needle):
    with pytest.raises(ValidationError, match=needle):
        sc.section([beam(motion=motion)])


def test_direction_must_match_the_scene():
    with pytest.raises(ValidationError, match=r"members\[0\]\.motion\.direction"):
        sc.section([beam(motion={"kind": "constant_velocity", "direction": [0, 0, 1]})])


def test_table_file_errors(tmp_path):
    bad = tmp_path / "m.csv"
    bad.write_text("# t,s\n0,0\n0,1\n")
    spec = sc.section([beam(motion={"kind": "table", "file": "m.csv"})])
    with pytest.raises(ValueError, match=r"structure.members\[0\].motion.file = 'm.csv': t must"):
        StructureParticipant(spec, base_dir=tmp_path)
    with pytest.raises(ValueError, match="no such file"):
        StructureParticipant(spec, base_dir=tmp_path / "nowhere")


# --------------------------------------------------------------------------- CLI
SCENARIO = """
title = "moving simply supported steel strip"
[run]
end_time = 2e-3
[output]
probe_interval = 5e-4
[structure]
record_interval = 5e-4
[structure.time]
dt = 1e-4
[[structure.members]]
name = "plate"
type = "beam"
start = [0.0, 0.0]
end = [0.4, 0.0]
elements = 10
bc = "simply_supported"
thickness = 0.01
[structure.members.material]
youngs_modulus = 2.1e11
density = 7800.0
[structure.members.motion]
kind = "table"
direction = [0.0, -1.0]
file = "motion.csv"
[[probes]]
name = "mid"
kind = "displacement"
target = "plate"
position = [0.2, 0.0]
"""


def test_mpsfem_structure_runs_with_motion(tmp_path):
    (tmp_path / "s.toml").write_text(SCENARIO)
    (tmp_path / "motion.csv").write_text("# t, s\n0.0,0.0\n1e-3,1e-3\n1.0,1e-3\n")
    out = tmp_path / "s.h5"
    env_src = str(Path(__file__).resolve().parents[2] / "src")
    r = subprocess.run(
        [sys.executable, "-m", "mpsfem", "structure", str(tmp_path / "s.toml"), "--out", str(out)],
        capture_output=True,
        text=True,
        env={"PYTHONPATH": env_src, "PATH": "/usr/bin:/bin", "NUMBA_NUM_THREADS": "1"},
        timeout=120,
    )
    assert r.returncode == 0, r.stderr
    with h5py.File(out) as h5:
        t = h5["structure/plate/time"][:]
        d = h5["structure/plate/displacement"][:]
        mid = h5["probes/mid/value"][:]
    assert t[-1] == pytest.approx(2e-3)
    # ends (supports) follow the table exactly; absolute records
    s = -np.interp(t, [0.0, 1e-3, 1.0], [0.0, 1e-3, 1e-3])
    np.testing.assert_allclose(d[:, 0, 1], s, atol=1e-15)
    np.testing.assert_allclose(d[:, -1, 1], s, atol=1e-15)
    # the stop at t = 1 ms throws the strip's middle on: it deflects relative to the supports
    assert np.abs(mid[-1, 1] - s[-1]) > 0.0


def test_dumped_motion_validates_again():
    """model_dump writes every key out (defaults too): the dump must be accepted again."""
    from mpsfem.scenario.structure import StructureSection

    for motion in (None, {"kind": "harmonic", "amplitude": 0.1, "period": 0.5}):
        s = sc.section([beam(motion=motion)])
        again = StructureSection.model_validate(s.model_dump())
        assert again.members[0].motion == s.members[0].motion
