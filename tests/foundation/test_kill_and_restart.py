"""A killed run leaves a readable results file; --restart reproduces the uninterrupted run bit for bit."""

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import h5py
import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]
SCENE = ROOT / "scenarios" / "dam_break_2d.toml"
SETS = [
    "--set",
    "fluid.spacing=0.0073",
    "--set",
    "output.checkpoint_interval=0.04",
    "--set",
    "output.snapshot_interval=0.02",
    "--set",
    "output.flush_interval=0.05",
    "--set",
    "run.threads=2",
]
END = "0.16"


def mpsfem(*args: str, **kw) -> subprocess.Popen:
    env = dict(os.environ, PYTHONUNBUFFERED="1")
    return subprocess.Popen(
        [sys.executable, "-m", "mpsfem.cli", *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        env=env,
        text=True,
        **kw,
    )


def probe(path: Path, name: str) -> tuple[np.ndarray, np.ndarray]:
    with h5py.File(path, "r") as h5:
        return h5[f"probes/{name}/time"][:], h5[f"probes/{name}/value"][:]


def last_snapshot(path: Path) -> dict[str, np.ndarray]:
    with h5py.File(path, "r") as h5:
        key = sorted(h5["particles"])[-1]
        g = h5["particles"][key]
        return {k: g[k][:] for k in ("pos", "vel", "p")} | {"time": g.attrs["time"]}


def assert_same_run(a: Path, b: Path) -> None:
    for name in ("front", "right_wall_p", "tank_force", "energy"):
        ta, va = probe(a, name)
        tb, vb = probe(b, name)
        np.testing.assert_array_equal(ta, tb)
        np.testing.assert_array_equal(va, vb)
    sa, sb = last_snapshot(a), last_snapshot(b)
    for k in sa:
        np.testing.assert_array_equal(sa[k], sb[k])


def signal_after_first_checkpoint(out: Path, sig: signal.Signals, end: str = END) -> tuple:
    """Start a run, send ``sig`` 0.3 s after its first checkpoint appears; (exit code, output)."""
    ckpt = out.with_name(out.stem + ".ckpt.h5")
    proc = mpsfem("run", str(SCENE), "--out", str(out), "--end-time", end, *SETS)
    deadline = time.time() + 600
    while not ckpt.exists() and time.time() < deadline and proc.poll() is None:
        time.sleep(0.02)
    time.sleep(0.3)
    proc.send_signal(sig)
    text, _ = proc.communicate(timeout=120)
    return proc.returncode, text


def resume(out: Path) -> None:
    """Restart the run of ``out`` from its checkpoint to END."""
    ckpt = out.with_name(out.stem + ".ckpt.h5")
    proc = mpsfem(
        "run", str(SCENE), "--out", str(out), "--end-time", END, "--restart", str(ckpt), *SETS
    )
    text, _ = proc.communicate(timeout=600)
    assert proc.returncode == 0, text


@pytest.fixture(scope="module")
def full(tmp_path_factory) -> Path:
    """The uninterrupted run."""
    path = tmp_path_factory.mktemp("full") / "full.h5"
    proc = mpsfem("run", str(SCENE), "--out", str(path), "--end-time", END, *SETS)
    out, _ = proc.communicate(timeout=600)
    assert proc.returncode == 0, out
    return path


def test_kill_then_restart_is_bit_identical(tmp_path, full):
    killed = tmp_path / "killed.h5"
    code, _ = signal_after_first_checkpoint(killed, signal.SIGKILL)
    assert code == -signal.SIGKILL, "the run finished before it could be killed"
    # the killed run's file opens and holds the probe series up to some time
    t_killed, _ = probe(killed, "front")
    assert t_killed.size > 0 and t_killed[-1] < float(END)
    resume(killed)
    assert_same_run(full, killed)


def test_sigterm_then_restart_is_bit_identical(tmp_path, full):
    """SIGTERM stops the run between steps and writes a checkpoint of the last good state at
    that moment, not at an interval: it carries the pressure preconditioner and the output
    schedule of that state, so the resumed run is the uninterrupted one, bit for bit."""
    stopped = tmp_path / "stopped.h5"
    code, text = signal_after_first_checkpoint(stopped, signal.SIGTERM)
    assert code == 1, f"the run was not stopped by the signal: {text}"
    t_stop = float(text.split("checkpoint of the last good state (t = ")[1].split(" s)")[0])
    assert t_stop % 0.04 > 1e-6  # between interval checkpoints
    resume(stopped)
    assert_same_run(full, stopped)


def test_checkpoint_interval_does_not_change_the_run(tmp_path, full):
    """Writing checkpoints at other times leaves the results alone (the preconditioner is
    carried, not rebuilt, at a checkpoint)."""
    other = tmp_path / "other.h5"
    sets = [*SETS, "--set", "output.checkpoint_interval=0.03"]
    proc = mpsfem("run", str(SCENE), "--out", str(other), "--end-time", END, *sets)
    out, _ = proc.communicate(timeout=600)
    assert proc.returncode == 0, out
    assert_same_run(full, other)


def test_sigterm_stops_between_steps_with_a_clear_status(tmp_path):
    """SIGTERM (a batch system's kill) ends the run at the end of the current step: status
    'failed: received signal SIGTERM' (not an error surfacing from inside a numba kernel), a
    readable file and a checkpoint to restart from."""
    out = tmp_path / "term.h5"
    code, text = signal_after_first_checkpoint(out, signal.SIGTERM, end="5.0")
    assert code == 1, text
    with h5py.File(out, "r") as h5:
        assert h5.attrs["status"] == "failed: received signal SIGTERM"
    with h5py.File(tmp_path / "term.ckpt.h5", "r") as h5:
        assert len(h5.keys()) > 0


def test_failure_in_the_first_sample_checkpoints_the_initial_state(tmp_path, monkeypatch):
    """A run failing before its first step (here: the first probe sample) still checkpoints a
    valid state, the initial one, not uninitialised memory."""
    from mpsfem.fluid_mps.solver import FluidSolver
    from mpsfem.results.checkpoint import read_checkpoint
    from mpsfem.scenario.loader import load_scenario
    from mpsfem.simulation import RunFailed, run_fluid

    loaded = load_scenario(SCENE, ["fluid.spacing=0.0146", "run.end_time=0.01"])

    def broken(self, probe):
        raise RuntimeError("probe failed")

    monkeypatch.setattr(FluidSolver, "probe_value", broken)
    with pytest.raises((RunFailed, RuntimeError)):
        run_fluid(loaded, tmp_path / "r.h5", progress=False, log=lambda msg: None)
    arrays, meta, _ = read_checkpoint(tmp_path / "r.ckpt.h5")
    fresh = FluidSolver(loaded.scenario.fluid).state()
    for key in ("pos", "vel", "p"):
        assert np.array_equal(arrays["fluid"][key], fresh[key]), key


FAIL_SCENE = """
[run]
end_time = 0.012
[output]
probe_interval = 0.001
snapshot_interval = 0.004
checkpoint_interval = 0
[fluid]
spacing = 0.01
[fluid.time_step]
dt_max = 1e-3
[[fluid.blocks]]
lower = [0.0, 0.0]
upper = [0.1, 0.1]
[[fluid.walls]]
shape = "tank"
lower = [0.0, 0.0]
upper = [0.3, 0.2]
"""


def test_a_failed_steps_state_is_flagged_and_a_restart_drops_it(tmp_path, monkeypatch):
    """A pressure solve failing in step 5 (t = 0.004 -> 0.005): the partly updated state is the
    last snapshot, flagged ``failure`` and left out of the sidecar; the restart from the last
    good state deletes it (before: it stayed, a second snapshot at t = 0.004 holding r*, u*)."""
    from mpsfem.fluid_mps import pressure_poisson
    from mpsfem.results.xdmf import xdmf_path
    from mpsfem.scenario.loader import load_scenario_text
    from mpsfem.simulation import RunFailed, run_fluid

    loaded = load_scenario_text(FAIL_SCENE)
    out = tmp_path / "r.h5"
    original = pressure_poisson.PressureSolver.solve
    calls = []

    def failing(self, *args, **kwargs):
        calls.append(1)
        if len(calls) == 5:
            raise pressure_poisson.PressureSolveError("injected: did not converge")
        return original(self, *args, **kwargs)

    monkeypatch.setattr(pressure_poisson.PressureSolver, "solve", failing)
    with pytest.raises(RunFailed, match="injected"):
        run_fluid(loaded, out, progress=False, log=lambda msg: None)
    monkeypatch.setattr(pressure_poisson.PressureSolver, "solve", original)
    with h5py.File(out, "r") as h5:
        snaps = [h5["particles"][k].attrs for k in sorted(h5["particles"])]
        assert [float(a["time"]) for a in snaps] == pytest.approx([0.0, 0.004, 0.004])
        assert ["failure" in a for a in snaps] == [False, False, True]
        assert "injected" in snaps[-1]["failure"]
    assert xdmf_path(out).read_text().count('GridType="Uniform"') == 2
    run_fluid(loaded, out, restart=tmp_path / "r.ckpt.h5", progress=False, log=lambda m: None)
    with h5py.File(out, "r") as h5:
        snaps = [h5["particles"][k].attrs for k in sorted(h5["particles"])]
        assert [float(a["time"]) for a in snaps] == pytest.approx([0.0, 0.004, 0.008, 0.012])
        assert not any("failure" in a for a in snaps)
        assert h5.attrs["status"] == "finished"
