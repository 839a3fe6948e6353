"""Coupled runs of the real MPS fluid and FEM structure (``simulation.run_coupled``, inproc).

Short runs of scenarios/hydrostatic_plate_2d.toml at a coarse spacing (l0 = 0.05 m: 20 x 40
fluid particles): the results-file contract, the hydrostatic load at t0, bit-identical restart,
and the failure paths (a window that does not converge stops the run with a message, a readable
results file and a checkpoint that restarts; ``on_divergence = "continue"`` records a warning).
"""

from __future__ import annotations

from pathlib import Path

import h5py
import numpy as np
import pytest

from mpsfem import simulation
from mpsfem.results.checkpoint import read_checkpoint
from mpsfem.scenario.loader import load_scenario
from mpsfem.simulation import RunFailed, run_coupled

ROOT = Path(__file__).resolve().parents[2]
SCENE = ROOT / "scenarios" / "hydrostatic_plate_2d.toml"
FAST = [
    "fluid.spacing=0.05",
    "run.threads=1",
    "output.snapshot_interval=0.002",
    "output.checkpoint_interval=0.0008",  # every 4 windows
    "output.probe_interval=0",
    "structure.record_interval=0",
]
WINDOW = 2e-4
RHO, G, H, L = 1000.0, 9.81, 2.0, 1.0


def run(tmp_path, name, end, extra=(), restart=None, out=None):
    loaded = load_scenario(SCENE, [*FAST, *extra])
    out = out or tmp_path / f"{name}.h5"
    return run_coupled(loaded, out, end, restart, progress=False, log=lambda m: None), out


def datasets(path) -> dict[str, np.ndarray]:
    out = {}

    def keep(name, obj):
        if isinstance(obj, h5py.Dataset):
            out[name] = obj[()]

    with h5py.File(path, "r") as h5:
        h5.visititems(keep)
    return out


def same_bits(a: dict, b: dict, skip=("coupling/wall_",)) -> list[str]:
    keys = [k for k in a if not k.startswith(skip)]
    return [k for k in keys if k not in b or a[k].tobytes() != b[k].tobytes()] + sorted(
        set(b) - set(a)
    )


@pytest.fixture(scope="module")
def ten_windows(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("coupled")
    summary, out = run(tmp, "full", 10 * WINDOW)
    return summary, out


def test_results_contract(ten_windows):
    summary, out = ten_windows
    assert summary.t == pytest.approx(10 * WINDOW)
    with h5py.File(out, "r") as h5:
        assert h5.attrs["status"] == "finished"
        g = h5["structure/plate"]
        assert g["nodes"].shape == (21, 2)
        assert g["displacement"].shape == (11, 21, 2) and g["time"].shape == (11,)
        c = h5["coupling"]
        assert c["time"].shape == (10,) and np.allclose(c["time"][:], WINDOW * np.arange(1, 11))
        assert (c["iterations"][:] >= 1).all() and (c["converged"][:] == 1).all()
        for k in ("residual", "energy_imbalance", "interface_work_error", "work_structure"):
            assert np.isfinite(c[k][:]).all(), k
        mid = h5["probes/mid_deflection"]
        assert list(mid.attrs["components"]) == ["ux", "uy"] and mid.attrs["unit"] == "m"
        # the mid-span probe is the middle node (20 elements)
        assert np.array_equal(mid["value"][:], g["displacement"][:, 10, :])
        assert mid["value"][-1, 1] < 0.0  # the water pushes the plate down
        assert list(h5["probes/plate_energy"].attrs["components"]) == ["kinetic", "strain"]
        snap = h5["particles"][sorted(h5["particles"])[-1]]
        kinds = set(np.unique(snap["kind"][:]).tolist())
        assert {0, 1, 2, 3, 4} <= kinds


def test_initial_load_is_the_water_column(ten_windows):
    """At t0 the plate carries rho g (H + l0/2) L: the pressure layer sits half a spacing
    below the wetted face and takes the hydrostatic pressure there."""
    _, out = ten_windows
    with h5py.File(out, "r") as h5:
        f0 = h5["probes/plate_force/value"][0]
    assert f0[1] == pytest.approx(-RHO * G * (H + 0.025) * L, rel=1e-12)
    assert abs(f0[0]) < 1e-9 * abs(f0[1])


def test_restart_is_bit_identical(tmp_path, ten_windows):
    """Restart from a checkpoint time of the uninterrupted run (window 4; the checkpoint carries
    the pressure preconditioner) continues it bit for bit."""
    _, full = ten_windows
    _, part = run(tmp_path, "part", 4 * WINDOW)
    ckpt = part.with_name("part.ckpt.h5")
    _, meta, _ = read_checkpoint(ckpt)
    assert meta["kind"] == "coupled" and meta["scheme"]["index"] == 4
    run(tmp_path, "part", 10 * WINDOW, restart=ckpt, out=part)
    a, b = datasets(full), datasets(part)
    assert len(a) > 30 and same_bits(a, b) == []


def test_checkpoint_interval_does_not_change_the_run(tmp_path, ten_windows):
    """Checkpoints every 3 windows instead of 4 leave every result bit-identical: writing one
    changes nothing in the running job (the fluid's preconditioner is carried, not reset)."""
    _, full = ten_windows
    _, other = run(tmp_path, "other", 10 * WINDOW, ["output.checkpoint_interval=0.0006"])
    assert same_bits(datasets(full), datasets(other)) == []


def test_stop_mid_run_then_restart_is_bit_identical(tmp_path, ten_windows, monkeypatch):
    """A stop request after window 6 (what SIGTERM does: ``_check_stop`` raises between
    windows) rolls the participants, the scheme, the preconditioner and the output schedule back
    to the start of window 6 and checkpoints there, between interval checkpoints; the restart
    from that checkpoint gives the uninterrupted run's bits."""
    _, full = ten_windows
    calls = []

    def stop_after_sixth_window():
        calls.append(1)
        if len(calls) == 6:
            raise simulation._Terminated("received signal SIGTERM")

    monkeypatch.setattr(simulation, "_check_stop", stop_after_sixth_window)
    with pytest.raises(RunFailed, match="received signal SIGTERM"):
        run(tmp_path, "stopped", 10 * WINDOW)
    monkeypatch.undo()
    out = tmp_path / "stopped.h5"
    ckpt = tmp_path / "stopped.ckpt.h5"
    _, meta, _ = read_checkpoint(ckpt)
    assert meta["scheme"]["index"] == 5  # the start of the window that was rolled back
    run(tmp_path, "stopped", 10 * WINDOW, restart=ckpt, out=out)
    a, b = datasets(full), datasets(out)
    assert same_bits(a, b) == []


def test_window_that_does_not_converge_stops_the_run(tmp_path):
    strict = [
        "coupling.convergence.max_iterations=2",
        "coupling.convergence.relative_tolerance=1e-12",
        'coupling.convergence.on_divergence="stop"',  # the scenario continues by default
    ]
    with pytest.raises(RunFailed) as err:
        run(tmp_path, "stop", 10 * WINDOW, strict)
    msg = str(err.value)
    assert "not converged after max_iterations = 2" in msg and "window 0" in msg
    out, ckpt = tmp_path / "stop.h5", tmp_path / "stop.ckpt.h5"
    assert str(out) in msg and str(ckpt) in msg
    with h5py.File(out, "r") as h5:
        assert h5.attrs["status"].startswith("failed: CouplingNotConvergedError")
        assert "coupling" not in h5 or h5["coupling/time"].shape[0] == 0
    # the checkpoint holds the last good state (t0) and a relaxed run continues from it
    _, meta, _ = read_checkpoint(ckpt)
    assert meta["scheme"]["t"] == 0.0
    summary, _ = run(tmp_path, "stop", 2 * WINDOW, restart=ckpt, out=out)
    assert summary.t == pytest.approx(2 * WINDOW)


def test_continue_on_divergence_records_a_warning(tmp_path):
    lax = [
        "coupling.convergence.max_iterations=2",
        "coupling.convergence.relative_tolerance=1e-12",
        'coupling.convergence.on_divergence="continue"',
    ]
    logged = []
    loaded = load_scenario(SCENE, [*FAST, *lax])
    out = tmp_path / "cont.h5"
    run_coupled(loaded, out, 3 * WINDOW, progress=False, log=logged.append)
    with h5py.File(out, "r") as h5:
        assert h5.attrs["status"] == "finished"
        assert (h5["coupling/converged"][:] == 0).all()
        assert (h5["coupling/iterations"][:] == 2).all()
    assert len([m for m in logged if "not converged" in m]) == 3


def test_explicit_added_mass_instability_is_detected(tmp_path):
    """scenarios/added_mass_plate_2d.toml (mass ratio 0.01, explicit coupling): the code stops
    the run at the added-mass instability, with the checkpoint one window back."""
    loaded = load_scenario(ROOT / "scenarios" / "added_mass_plate_2d.toml", ["run.threads=1"])
    out = tmp_path / "am.h5"
    with pytest.raises(RunFailed) as err:
        run_coupled(loaded, out, progress=False, log=lambda m: None)
    msg = str(err.value)
    assert "CouplingDivergedError" in msg and "added-mass instability" in msg
    with h5py.File(out, "r") as h5:
        assert h5.attrs["status"].startswith("failed: CouplingDivergedError")
        n = h5["coupling/time"].shape[0]
    _, meta, _ = read_checkpoint(tmp_path / "am.ckpt.h5")
    assert 4 <= n < 30 and meta["scheme"]["index"] == n


def test_static_start_scheme_starts_from_the_structures_start_state():
    """``initial_state = "static"``: the structure rebuilds its start state under the first
    forces written (K u0 = F_self + F_water), so the scheme reads d, v only after writing them.
    Its d (what the fluid's wall, the probes and the predictor use) is then the structure's own
    state, and the first window starts in equilibrium: its explicit residual is a small part of
    the static deflection (the self-weight-only shape gave 40 % of it)."""
    from mpsfem.coupler.coupling_scheme import create_scheme
    from mpsfem.fluid_mps.participant import FluidParticipant
    from mpsfem.structure_fem.participant import StructureParticipant

    loaded = load_scenario(
        SCENE, [*FAST, 'structure.initial_state="static"', 'coupling.scheme="explicit"']
    )
    sc = loaded.scenario
    st = StructureParticipant(sc.structure, base_dir=SCENE.parent)
    fl = FluidParticipant(sc.fluid, st.interface(), base_dir=SCENE.parent, member_names=["plate"])
    scheme = create_scheme(fl, st, sc.coupling)
    scheme.initialize()
    d0 = st.read("displacement")
    assert np.array_equal(scheme.d, d0) and np.array_equal(scheme.v, st.read("velocity"))
    assert np.array_equal(scheme.d_f, scheme.mapping.to_fluid(d0))
    w_mid = d0[10, 1]
    assert w_mid == pytest.approx(-6.86e-5, rel=0.05)  # water + self weight, beam theory
    rec = scheme.advance_window()
    assert rec.residual_abs < 0.05 * abs(w_mid)


def test_imvj_restart_is_bit_identical(tmp_path):
    """IQN-IMVJ's state (its RS-SVD terms, compressed every 2 windows, the scaling weights, the
    complement relaxation's slope) goes through the checkpoint file (HDF5 arrays, JSON numbers):
    a run restarted at window 5 of the MPS fluid with the FEM plate continues bit for bit."""
    imvj = ['coupling.acceleration={kind = "iqn-imvj", chunk_size = 2}']
    _, full = run(tmp_path, "full", 8 * WINDOW, extra=imvj)
    _, part = run(tmp_path, "part", 5 * WINDOW, extra=[*imvj, "output.checkpoint_interval=0.001"])
    ckpt = part.with_name("part.ckpt.h5")
    _, meta, _ = read_checkpoint(ckpt)
    assert meta["scheme"]["index"] == 5 and meta["scheme"]["acceleration/imvj/restarts"] == 2
    run(tmp_path, "part", 8 * WINDOW, extra=imvj, restart=ckpt, out=part)
    a, b = datasets(full), datasets(part)
    assert len(a) > 30 and same_bits(a, b) == []
