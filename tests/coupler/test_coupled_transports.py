"""The same coupled case gives bit-identical results on every transport and launch form: the mock
participants (``coupler.demo``), and the MPS and δ-SPH fluids with the FEM structure (``mpsfem
run``). A structure process that dies stops the fluid's run with a message and a readable results
file."""

from __future__ import annotations

import json
import signal
import time
from pathlib import Path

import numpy as np
import pytest
from conftest import MPIRUN, PY, free_port, mpi_cmd, needs_mpi, run

DEMO = ["-m", "mpsfem.coupler.demo", "--mass-ratio", "3", "--end-time", "0.02"]


def launch(form: str, out) -> None:
    out = str(out)
    if form == "inproc":
        cmd = [PY, *DEMO, "--transport", "inproc", "--out", out]
    elif form == "inproc-thread":
        cmd = [PY, *DEMO, "--transport", "inproc-thread", "--out", out]
    elif form == "mpi":
        cmd = mpi_cmd(*DEMO, "--transport", "mpi", "--out", out)
    elif form == "mpi-mpmd":
        cmd = [
            MPIRUN, "-n", "1", PY, *DEMO, "--transport", "mpi", "--participant", "fluid",
            "--out", out, ":", "-n", "1", PY, *DEMO, "--transport", "mpi",
            "--participant", "structure",
        ]  # fmt: skip
    else:
        ep = f"tcp/127.0.0.1:{free_port()}"
        cmd = [PY, *DEMO, "--transport", "zenoh", "--endpoint", ep, "--out", out]
    rc, stdout, stderr, wall = run(cmd, timeout=120)
    assert rc == 0, stderr


FORMS = ["inproc-thread", "zenoh"] + (["mpi", "mpi-mpmd"] if MPIRUN else [])


@pytest.fixture(scope="module")
def baseline(tmp_path_factory):
    path = tmp_path_factory.mktemp("coupled") / "inproc.npz"
    launch("inproc", path)
    return np.load(path)


@pytest.mark.parametrize("form", FORMS)
def test_bit_identical_across_transports(form, baseline, tmp_path):
    path = tmp_path / f"{form}.npz"
    launch(form, path)
    other = np.load(path)
    assert sorted(other.files) == sorted(baseline.files)
    differ = [k for k in baseline.files if baseline[k].tobytes() != other[k].tobytes()]
    assert not differ, differ
    assert baseline["history/iterations"].size == 20 and baseline["history/converged"].all()


@needs_mpi
def test_mpi_needs_two_ranks():
    rc, out, err, _ = run(mpi_cmd(*DEMO, "--transport", "mpi", n=1), timeout=60)
    assert rc != 0 and "needs exactly 2 MPI ranks" in err


# ---------------------------------------------------------------- the real solvers, mpsfem run
import h5py  # noqa: E402
from conftest import reap, spawn  # noqa: E402

from mpsfem.results.checkpoint import read_checkpoint  # noqa: E402

SCENE = str(Path(__file__).resolve().parents[2] / "scenarios" / "hydrostatic_plate_2d.toml")
SETS = [
    "--set", "fluid.spacing=0.05", "--set", "run.threads=1",
    "--set", "output.snapshot_interval=0.001", "--set", "output.probe_interval=0",
]  # fmt: skip
RUN = ["-m", "mpsfem.cli", "run", SCENE, "--no-progress", *SETS]
END = ["--end-time", "0.002"]  # ten implicit windows


def zenoh_sets() -> list[str]:
    ep = f"tcp/127.0.0.1:{free_port()}"
    return ["--set", f'coupling.transport={{kind = "zenoh", endpoint = "{ep}"}}']


#: the fluid methods the real-solver forms run under, as ``--set`` items of the fluid's program
METHOD_SETS = {"mps": [], "delta-sph": ["--set", 'fluid.method="delta-sph"']}


def launch_run(
    form: str, out: Path, method: str = "mps", structure_method: str | None = None
) -> None:
    """``mpsfem run`` of the hydrostatic plate in launch form ``form`` with ``fluid.method =
    method`` in the fluid's program; the structure's program (the MPMD and two-program forms)
    gets ``structure_method`` (default: the same), so a test can show that it need not know the
    fluid's method."""
    o = ["--out", str(out)]
    fl = [*RUN, *METHOD_SETS[method]]
    st = [*RUN, *METHOD_SETS[structure_method or method]]
    if form == "inproc":
        cmd = [PY, *fl, *END, *o]
    elif form == "mpi":
        cmd = mpi_cmd(*fl, *END, *o, "--transport", "mpi")
    elif form == "mpi-mpmd":
        cmd = [
            MPIRUN, "-n", "1", PY, *fl, *END, *o, "--transport", "mpi", "--participant", "fluid",
            ":", "-n", "1", PY, *st, "--transport", "mpi", "--participant", "structure",
        ]  # fmt: skip
    elif form == "zenoh":  # the fluid starts the structure itself
        cmd = [PY, *fl, *END, *o, *zenoh_sets()]
    else:  # zenoh, one program per participant
        z = zenoh_sets()
        structure = spawn([PY, *st, *z, "--participant", "structure"])
        rc, _, err, _ = run([PY, *fl, *END, *o, *z, "--participant", "fluid"], timeout=180)
        src, _, serr = reap(structure, timeout=30)
        assert rc == 0 and src == 0, err + serr
        return
    rc, _, err, _ = run(cmd, timeout=180)
    assert rc == 0, err


def h5_datasets(path: Path) -> dict[str, bytes]:
    out = {}

    def keep(name, obj):
        if isinstance(obj, h5py.Dataset):
            out[name] = obj[()].tobytes()

    with h5py.File(path, "r") as h5:
        assert h5.attrs["status"] == "finished"
        h5.visititems(keep)
    return out


REAL_FORMS = ["zenoh", "zenoh-two"] + (["mpi", "mpi-mpmd"] if MPIRUN else [])


@pytest.fixture(scope="module")
def real_baseline(tmp_path_factory):
    path = tmp_path_factory.mktemp("real") / "inproc.h5"
    launch_run("inproc", path)
    return h5_datasets(path)


@pytest.mark.parametrize("form", REAL_FORMS)
def test_real_coupled_run_bit_identical_across_transports(form, real_baseline, tmp_path):
    """MPS fluid + FEM plate, implicit IQN-ILS: every dataset of the results file but the
    wall-clock columns /coupling/wall_* is the same on every transport and launch form."""
    path = tmp_path / f"{form}.h5"
    launch_run(form, path)
    other = h5_datasets(path)
    keys = [k for k in real_baseline if not k.startswith("coupling/wall_")]
    assert sorted(other) == sorted(real_baseline)
    assert [k for k in keys if other[k] != real_baseline[k]] == []
    assert len(keys) > 30


#: δ-SPH over the two forms whose participants are separate programs started apart: every
#: byte between them crosses the link (zenoh-two over TCP, mpi-mpmd over MPI), and each program
#: parses the scenario on its own. The other two forms differ from these only in who starts the
#: structure's program (zenoh: the fluid spawns it; mpi: one mpirun with rank = role); the
#: participants, the RemoteParticipant messages and the fluid's side are the same code, and the
#: MPS rows above run all four.
SPH_FORMS = ["zenoh-two"] + (["mpi-mpmd"] if MPIRUN else [])


@pytest.fixture(scope="module")
def sph_baseline(tmp_path_factory):
    path = tmp_path_factory.mktemp("real_sph") / "inproc.h5"
    launch_run("inproc", path, "delta-sph")
    return h5_datasets(path)


@pytest.mark.parametrize("form", SPH_FORMS)
def test_delta_sph_coupled_run_bit_identical_across_transports(form, sph_baseline, tmp_path):
    """δ-SPH fluid + FEM plate, implicit IQN-ILS, ten windows: the same bits as in process. Under
    mpi-mpmd the structure's program is given the scenario without the method (its file says
    "mps"): the structure side builds from [structure] alone and need not know the fluid."""
    path = tmp_path / f"{form}.h5"
    launch_run(form, path, "delta-sph", "mps" if form == "mpi-mpmd" else None)
    other = h5_datasets(path)
    keys = [k for k in sph_baseline if not k.startswith("coupling/wall_")]
    assert sorted(other) == sorted(sph_baseline)
    assert [k for k in keys if other[k] != sph_baseline[k]] == []
    assert len(keys) > 30
    with h5py.File(path, "r") as h5:  # the run is δ-SPH's, and it coupled (iterations > 1)
        assert json.loads(h5.attrs["scenario_resolved"])["fluid"]["method"] == "delta-sph"
        assert h5["coupling/iterations"][()].max() > 1


def _windows_recorded(out) -> bool:
    """Whether the running writer has flushed at least one coupling window into ``out``."""
    try:
        with h5py.File(out, "r", locking=False) as h5:
            return "coupling/time" in h5 and h5["coupling/time"].shape[0] > 0
    except (OSError, KeyError, RuntimeError):  # caught mid-flush (h5py: 'addr overflow'): not yet
        return False


def test_lost_structure_stops_the_fluid_within_10_s(tmp_path):
    """The structure process is killed mid-run: the fluid stops with PeerLostError within the
    transport timeout (10 s), and leaves a readable results file marked failed."""
    out = tmp_path / "lost.h5"
    z = zenoh_sets()
    structure = spawn([PY, *RUN, *z, "--participant", "structure"])
    fluid = spawn([PY, *RUN, "--end-time", "5.0", "--out", str(out), *z, "--participant", "fluid"])
    t0 = time.monotonic()
    while not out.exists() and time.monotonic() - t0 < 120:
        time.sleep(0.2)
    while not _windows_recorded(out) and time.monotonic() - t0 < 120:
        time.sleep(0.2)  # until windows are running (slow to start on a loaded machine)
    assert fluid.poll() is None
    structure.kill()
    killed = time.monotonic()
    rc, _, err = reap(fluid, timeout=30)
    waited = time.monotonic() - killed
    reap(structure)
    print(f"the fluid stopped {waited:.2f} s after the structure was killed")
    assert rc == 1, err
    assert "PeerLostError" in err and str(out) in err
    assert waited < 10.0 + 5.0  # timeout plus process exit
    with h5py.File(out, "r") as h5:
        assert h5.attrs["status"].startswith("failed: PeerLostError")
        assert h5["coupling/time"].shape[0] > 0


@needs_mpi
def test_sigterm_to_mpirun_stops_both_ranks_cleanly(tmp_path):
    """What a batch scheduler sends at the wall-time limit: mpirun forwards SIGTERM to both
    ranks. The structure rank serves on (it used to die at once, and mpirun then killed the
    fluid: no message, results left "running", no final checkpoint); the fluid stops at its
    window end, restores both, checkpoints there and finalises the structure."""
    out = tmp_path / "term.h5"
    cmd = mpi_cmd(*RUN, "--end-time", "5.0", "--out", str(out), "--transport", "mpi")
    p = spawn(cmd)
    t0 = time.monotonic()
    while not _windows_recorded(out) and time.monotonic() - t0 < 120 and p.poll() is None:
        time.sleep(0.2)
    assert p.poll() is None, reap(p)[2]
    p.send_signal(signal.SIGTERM)
    rc, _, err = reap(p, timeout=60)
    assert rc != 0 and "BAD TERMINATION" not in err, err
    assert "structure participant: SIGTERM received" in err
    assert "structure participant finished at t =" in err
    assert "a checkpoint of the last good window" in err
    with h5py.File(out, "r") as h5:
        assert h5.attrs["status"] == "failed: _Terminated: received signal SIGTERM"
        t_last = h5["coupling/time"][-1]
    _, meta, _ = read_checkpoint(out.with_name("term.ckpt.h5"))
    assert meta["scheme"]["t"] <= t_last


@pytest.mark.parametrize("acceleration", ["iqn-imvj"])
def test_imvj_bit_identical_over_a_remote_participant(acceleration, tmp_path):
    """IQN-IMVJ (its defaults: both fields, value scaling, "auto" complement relaxation) gives
    the same bits with the structure called directly and through a RemoteParticipant over a
    thread link (message encoding, read_many), like the default accelerator above on every
    transport: the accelerator runs in the fluid's process on the arrays that arrive."""
    from mpsfem.coupler import demo

    paths = {}
    for form in ("inproc", "inproc-thread"):
        paths[form] = tmp_path / f"{form}.npz"
        args = ["--transport", form, "--acceleration", acceleration, "--mass-ratio", "30"]
        assert demo.main([*args, "--end-time", "0.02", "--out", str(paths[form])]) == 0
    a, b = (np.load(p) for p in paths.values())
    assert sorted(a.files) == sorted(b.files)
    assert not [k for k in a.files if a[k].tobytes() != b[k].tobytes()]
    assert a["history/iterations"].size == 20 and a["history/converged"].all()
