"""Nonlinear structure path around the co-rotational beam: the linear path unchanged, the HHT
scheme, Newton's failure message, the large-rotation warning, checkpoints, schema and runs."""

import hashlib
import math
import warnings

import h5py
import numpy as np
import pytest
import scipy
from structure_cases import BEAM, PLATE, section

from mpsfem.structure_fem.alpha_method import NonlinearNewmark
from mpsfem.structure_fem.newmark import Newmark
from mpsfem.structure_fem.newton import NewtonFailure
from mpsfem.structure_fem.participant import LargeRotationWarning, StructureParticipant
from mpsfem.structure_fem.standalone import run_structure

# sha256 of every read() of the runs below, recorded with the code of commit e140017 (before
# the nonlinear path existed) on the development VM: numpy 2.x / scipy 1.17.1
BEAM_RUN_SHA = "a58681df3bad9dfb8a1c9a633f22173bb1c6102790859dd5855a39e792543c84"
PLATE_RUN_SHA = "f3e286306e0abc33ae1399e3a8987cf2890bc4d482fc7834363f5ecc4178befc"


def corot(**kw):
    m = dict(BEAM, name="flap", kinematics="corotational", rayleigh_a2=0.0)
    m.update(kw)
    return m


def beam_run(sec) -> tuple[str, StructureParticipant]:
    p = StructureParticipant(sec)
    n = p.interface().n_points
    rng = np.random.default_rng(7)
    h = hashlib.sha256()
    for _ in range(40):
        p.write("forces", 50.0 * rng.standard_normal((n, 2)))
        p.advance(2.5e-4)
        for name in ("displacement", "velocity", "acceleration", "rotation"):
            h.update(np.ascontiguousarray(p.read(name)).tobytes())
    return h.hexdigest(), p


def beam_section(**member):
    sec = section([dict(BEAM, **member)], initial_state="static", gravity=[0.0, -9.81])
    sec.members[0].self_weight = True
    return sec


# --------------------------------------------------------------------------- linear path
def test_linear_path_is_bit_identical_to_the_linear_newmark():
    """Default and explicit kinematics = "linear" run the linear Newmark integrator and give the
    same bits as the code before the nonlinear path (recorded hash) and as each other."""
    sha_default, p = beam_run(beam_section())
    sha_explicit, _ = beam_run(beam_section(kinematics="linear"))
    assert type(p.integrator) is Newmark
    assert sha_default == sha_explicit
    if scipy.__version__ == "1.17.1" and np.__version__.startswith("2."):
        assert sha_default == BEAM_RUN_SHA

    p3 = StructureParticipant(section([PLATE]))
    n = p3.interface().n_points
    rng = np.random.default_rng(7)
    h = hashlib.sha256()
    for _ in range(20):
        p3.write("forces", 5.0 * rng.standard_normal((n, 3)))
        with warnings.catch_warnings():  # random forces tilt the thin plate beyond 0.1 rad
            warnings.simplefilter("ignore", LargeRotationWarning)
            p3.advance(2.5e-4)
        for name in ("displacement", "velocity", "acceleration"):
            h.update(np.ascontiguousarray(p3.read(name)).tobytes())
    assert type(p3.integrator) is Newmark
    if scipy.__version__ == "1.17.1" and np.__version__.startswith("2."):
        assert h.hexdigest() == PLATE_RUN_SHA


def test_hht_with_alpha_zero_is_newmark_through_newton():
    """A linear member under scheme = "hht", hht_alpha = 0 (average acceleration through the
    Newton integrator) matches the linear Newmark to round-off, one iteration per step."""
    lin = StructureParticipant(section([BEAM]))
    hht = StructureParticipant(
        section([BEAM], time={"dt": 1e-4, "scheme": "hht", "hht_alpha": 0.0})
    )
    assert isinstance(hht.integrator, NonlinearNewmark)
    n = lin.interface().n_points
    rng = np.random.default_rng(1)
    for _ in range(30):
        f = 20.0 * rng.standard_normal((n, 2))
        for p in (lin, hht):
            p.write("forces", f)
            p.advance(1e-4)
    a, b = lin.read("displacement"), hht.read("displacement")
    assert np.abs(a - b).max() <= 1e-9 * np.abs(a).max()
    assert hht.integrator.iterations == 30  # linear: the kept Jacobian is exact
    assert hht.integrator.factorizations == 1


def test_hht_damps_the_high_modes_of_a_linear_member():
    """Undamped free vibration from a random (mostly high-mode) velocity: average acceleration
    keeps the energy exactly, HHT (alpha = -0.3, spectral radius 0.54 at omega dt -> infinity)
    removes the modes it cannot resolve."""
    rng = np.random.default_rng(2)
    ratios = {}
    for name, t in (
        ("newmark", {"dt": 1e-3}),
        ("hht", {"dt": 1e-3, "scheme": "hht", "hht_alpha": -0.3}),
    ):
        p = StructureParticipant(section([dict(BEAM, rayleigh_a2=0.0)], time=t))
        it = p.integrator
        v0 = rng.standard_normal(p.system.n) if not ratios else ratios["v0"]
        ratios["v0"] = v0
        it.initialize(np.zeros(p.system.n), v0=v0)
        E0 = sum(p.energy())
        for _ in range(20):
            p.advance(1e-3)
        ratios[name] = sum(p.energy()) / E0
    print("energy after 20 steps / initial:", ratios["newmark"], ratios["hht"])
    assert ratios["newmark"] == pytest.approx(1.0, abs=1e-10)
    assert ratios["hht"] < 0.5


# --------------------------------------------------------------------------- newton failure
def test_newton_failure_names_member_step_time_and_residual():
    load = {"kind": "point_force", "member": "flap", "position": [0.0, 0.25], "force": [30.0, 0]}
    sec = section(
        [corot(bc=["clamped", "free"])],
        loads=[load],
        newton={"max_iterations": 2, "tolerance": 1e-12},
        time={"dt": 5e-2},
    )
    p = StructureParticipant(sec, prescribed_loads=True)
    with pytest.raises(NewtonFailure) as info:
        for _ in range(5):
            p.advance(5e-2)
    msg = str(info.value)
    print(msg)
    assert "'flap'" in msg and "step 1 " in msg and "t = 0 s" in msg
    assert "residual" in msg and "structure.newton.max_iterations" in msg
    assert isinstance(info.value, FloatingPointError)  # the CLI reports it as a stopped run


def test_static_start_failure_names_the_static_start():
    load = {"kind": "point_force", "member": "flap", "position": [0.0, 0.25], "force": [1e9, 0]}
    sec = section(
        [corot(bc=["clamped", "free"])],
        loads=[load],
        initial_state="static",
        newton={"max_iterations": 1},
    )
    with pytest.raises(NewtonFailure, match="static start"):
        StructureParticipant(sec, prescribed_loads=True)


# --------------------------------------------------------------------------- warning
def test_linear_member_warns_once_beyond_a_tenth_of_a_radian():
    load = {"kind": "point_force", "member": "wall", "position": [0.0, 0.25], "force": [800.0, 0]}
    sec = section([dict(BEAM, bc=["clamped", "free"])], loads=[load], initial_state="static")
    p = StructureParticipant(sec, prescribed_loads=True)
    assert np.abs(p.read("rotation")).max() > 0.1
    with pytest.warns(LargeRotationWarning) as rec:
        for _ in range(3):
            p.advance(1e-4)
    assert len(rec) == 1
    msg = str(rec[0].message)
    assert "'wall'" in msg and 'kinematics = "corotational"' in msg and "0.1 rad" in msg
    # the same member, co-rotational: no warning
    sec2 = section(
        [corot(name="wall", bc=["clamped", "free"])], loads=[load], initial_state="static"
    )
    p2 = StructureParticipant(sec2, prescribed_loads=True)
    with warnings.catch_warnings():
        warnings.simplefilter("error", LargeRotationWarning)
        p2.advance(1e-4)


# --------------------------------------------------------------------------- participant
def test_corotational_checkpoint_restore_repeats_bit_for_bit():
    p = StructureParticipant(section([corot()]))
    n = p.interface().n_points
    rng = np.random.default_rng(5)
    forces = [200.0 * rng.standard_normal((n, 2)) for _ in range(6)]
    for f in forces[:2]:
        p.write("forces", f)
        p.advance(1e-4)
    p.checkpoint()
    first = []
    for f in forces[2:]:
        p.write("forces", f)
        p.advance(1e-4)
        first.append(p.read("displacement").copy())
    p.restore()
    for f, ref in zip(forces[2:], first, strict=True):
        p.write("forces", f)
        p.advance(1e-4)
        assert np.array_equal(p.read("displacement"), ref)


def test_small_motion_of_a_corotational_member_matches_the_linear_one():
    """Under a small load the co-rotational member moves like the linear Hermite one (same EI,
    EA; its mass differs at O(h^2), so compare the static start)."""
    load = {"kind": "point_force", "member": "wall", "position": [0.0, 0.25], "force": [1e-3, 0]}
    lin = StructureParticipant(
        section([dict(BEAM, bc=["clamped", "free"])], loads=[load], initial_state="static"),
        prescribed_loads=True,
    )
    cr = StructureParticipant(
        section([corot(name="wall", bc=["clamped", "free"])], loads=[load], initial_state="static"),
        prescribed_loads=True,
    )
    a, b = lin.read("displacement"), cr.read("displacement")
    assert np.abs(a - b).max() <= 1e-6 * np.abs(a).max()
    assert np.allclose(lin.read("rotation"), cr.read("rotation"), rtol=1e-6, atol=1e-12)


# --------------------------------------------------------------------------- schema
def test_schema_keys_of_the_nonlinear_path():
    with pytest.raises(ValueError, match="axial"):
        section([corot(axial=False)])
    with pytest.raises(ValueError, match="newmark_beta"):
        section([BEAM], time={"dt": 1e-4, "scheme": "hht", "newmark_beta": 0.3})
    with pytest.raises(ValueError, match="hht_alpha"):
        section([BEAM], time={"dt": 1e-4, "hht_alpha": -0.1})
    with pytest.raises(ValueError, match="hht_alpha"):
        section([BEAM], time={"dt": 1e-4, "scheme": "hht", "hht_alpha": -0.5})
    with pytest.raises(ValueError, match="kinematics"):
        section([dict(BEAM, kinematics="nonlinear")])
    t = section([BEAM], time={"dt": 1e-4, "scheme": "hht", "hht_alpha": -0.2}).time
    assert t.beta == pytest.approx(1.2**2 / 4) and t.gamma == pytest.approx(0.7)


# --------------------------------------------------------------------------- standalone
def test_standalone_run_of_a_corotational_member_under_hht(tmp_path):
    from structure_cases import root_model

    data = {
        "run": {"end_time": 0.02},
        "output": {"probe_interval": 0.0},
        "structure": {
            "members": [corot(bc=["clamped", "free"])],
            "time": {"dt": 1e-3, "scheme": "hht", "hht_alpha": -0.1},
            "loads": [
                {
                    "kind": "point_force", "member": "flap", "position": [0.0, 0.25],
                    "force": [3000.0, 0.0], "time": {"kind": "ramp", "duration": 0.01},
                }
            ],
        },
        "probes": [
            {"name": "tip", "kind": "displacement", "target": "flap", "position": [0.0, 0.25]},
            {"name": "energy", "kind": "energy", "target": "flap"},
        ],
    }  # fmt: skip
    root = root_model().model_validate(data)
    out = tmp_path / "flap.h5"
    summary = run_structure(root, out, progress=False)
    assert summary.steps == 20
    with h5py.File(out, "r") as h5:
        assert h5.attrs["status"] == "finished"
        e = h5["probes/energy"]
        assert "HHT" in e.attrs["meaning"] and "end of each step" in e.attrs["meaning"]
        tip = h5["probes/tip/value"][:]
        assert tip[:, 0].max() > 0.05  # pushed along +x: P L^2 / EI = 1, static 0.3 L
        assert math.isfinite(float(tip[-1, 1]))


def test_cli_runs_a_corotational_scenario(tmp_path, monkeypatch, capsys):
    """`mpsfem structure SCENARIO.toml` with a co-rotational member under HHT (the demo
    cantilever, its tip load raised to P L^2 / EI = 1)."""
    from pathlib import Path
    from types import SimpleNamespace

    from structure_cases import load

    import mpsfem.scenario.loader as loader
    from mpsfem.structure_fem.standalone import cli_main

    demo = Path(__file__).resolve().parents[2] / "scenarios" / "structure_cantilever_demo.toml"
    text = (
        demo.read_text()
        .replace(
            'bc = ["clamped", "free"]', 'bc = ["clamped", "free"]\nkinematics = "corotational"'
        )
        .replace("newmark_beta = 0.25\nnewmark_gamma = 0.5", 'scheme = "hht"\nhht_alpha = -0.1')
        .replace("force = [0.0, -100.0]", "force = [0.0, -17500.0]")
    )
    scen = tmp_path / "corot.toml"
    scen.write_text(text)
    monkeypatch.setattr(loader, "load_scenario", lambda path, overrides=(): load(path, overrides))
    h5 = tmp_path / "corot.h5"
    rc = cli_main(
        SimpleNamespace(
            command="structure", scenario=scen, overrides=["run.end_time=0.06"], out=h5,
            no_progress=True,
        )
    )  # fmt: skip
    assert rc == 0, capsys.readouterr().err
    with h5py.File(h5, "r") as f:
        tip = f["probes/tip/value"][:]
    # a half period after the step load: swung well past the static elastica (0.30 L down)
    assert tip[:, 1].min() < -0.3
    assert tip[:, 0].min() < -0.05  # and shortened horizontally: large rotation


def test_newton_converges_on_a_motion_decayed_to_round_off():
    """A state at 1e-30 m still converges (the residual's own round-off floor)."""
    p = StructureParticipant(section([corot()]))
    it = p.integrator
    it.initialize(np.zeros(p.system.n), v0=1e-30 * np.ones(p.system.n))
    for _ in range(5):
        p.advance(1e-4)
    assert np.isfinite(p.read("displacement")).all()


def test_plate_under_hht():
    """A linear plate under the HHT scheme takes the Newton integrator (sparse Jacobian)."""
    p = StructureParticipant(section([PLATE], time={"dt": 1e-4, "scheme": "hht"}))
    assert isinstance(p.integrator, NonlinearNewmark)
    f = np.zeros((p.interface().n_points, 3))
    f[:, 2] = 1.0
    for _ in range(3):
        p.write("forces", f)
        p.advance(1e-4)
    assert p.read("displacement")[:, 2].max() > 0
    assert p.integrator.iterations == 3


def test_corotational_member_in_an_implicit_coupling_loop():
    """The co-rotational beam coupled to the coupler's added-mass mock fluid (heavy fluid,
    implicit IQN-ILS, checkpoint/restore every iteration): the windows converge."""
    from mpsfem.coupler import mock
    from mpsfem.coupler.coupling_scheme import create_scheme
    from mpsfem.scenario.coupling import CouplingSection

    st = StructureParticipant(section([corot()]))
    m_beam = 1100.0 * 0.04 * 0.25
    fluid = mock.AddedMassFluid(
        st, mass_ratio=2.0, spacing=0.005, pressure=200.0, dt=4e-5, structure_mass=m_beam
    )
    sch = create_scheme(
        fluid, st, CouplingSection.model_validate({"mapping": {"kind": "shape-function"}})
    )
    sch.run(0.005)
    h = sch.history_arrays()
    print("iterations per window:", h["iterations"].min(), "-", h["iterations"].max())
    assert h["converged"].all() and h["iterations"].max() < 10
    assert 0 < np.abs(st.read("displacement")).max() < 1e-2


def test_schema_round_trips_through_model_dump():
    """A dumped section (defaults written out) validates again, under either scheme."""
    for t in ({"dt": 1e-4}, {"dt": 1e-4, "scheme": "hht", "hht_alpha": -0.2}):
        sec = section([corot()], time=t)
        again = type(sec).model_validate(sec.model_dump())
        assert again.time == sec.time and again.members[0].kinematics == "corotational"


def test_linear_plate_warns_beyond_a_tenth_of_a_radian_of_slope():
    load = {"kind": "pressure", "member": "deck", "value": 2000.0}
    sec = section([dict(PLATE, bc="simply_supported")], loads=[load], initial_state="static")
    p = StructureParticipant(sec, prescribed_loads=True)
    assert np.abs(p.read("rotation")).max() > math.tan(0.1)
    with pytest.warns(LargeRotationWarning, match='kinematics = "von_karman"'):
        p.advance(1e-4)


def test_static_start_of_an_unsupported_corotational_member_says_so():
    with pytest.raises(ValueError, match="supported against rigid motion"):
        StructureParticipant(section([corot(bc="free")], initial_state="static"))
