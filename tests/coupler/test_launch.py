"""The launch glue (``coupler.launch``): which role a process takes, refusing a launch that
would run the whole coupled simulation in every rank of an MPI job, and the structure's serve
loop riding out SIGTERM/SIGINT until the fluid finalises it."""

from __future__ import annotations

import os
import signal
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from mpsfem.coupler import mock
from mpsfem.coupler.launch import (
    MPI_SIZE_VARIABLES,
    deferred_signals,
    mpi_job_size,
    participant_role,
)
from mpsfem.coupler.remote import RemoteParticipant, serve
from mpsfem.coupler.transport.inproc import InprocTransport
from mpsfem.scenario.loader import load_scenario
from mpsfem.simulation import run_coupled

SCENE = Path(__file__).resolve().parents[2] / "scenarios" / "hydrostatic_plate_2d.toml"


@pytest.fixture
def no_mpi_env(monkeypatch):
    for name in MPI_SIZE_VARIABLES:
        monkeypatch.delenv(name, raising=False)
    return monkeypatch


@pytest.mark.parametrize("var", MPI_SIZE_VARIABLES)
def test_job_size_from_the_launchers_environment(var):
    assert mpi_job_size({var: "2"}) == (2, var)
    assert mpi_job_size({var: "1"}) is None and mpi_job_size({}) is None
    assert mpi_job_size({var: "x"}) is None


def test_inproc_under_mpirun_is_refused_before_any_compute(no_mpi_env, tmp_path):
    """``mpirun -n 2 mpsfem run <coupled>`` without ``--transport mpi``: both ranks would run the
    in-process simulation into the same file; the run stops before building anything."""
    no_mpi_env.setenv("PMI_SIZE", "2")
    loaded = load_scenario(SCENE, ["fluid.spacing=0.05", "run.threads=1"])
    out = tmp_path / "twice.h5"
    with pytest.raises(ValueError, match=r"2 MPI ranks \(PMI_SIZE=2\).*--transport mpi") as err:
        run_coupled(loaded, out, 2e-4, progress=False, log=lambda m: None)
    assert "allowed: inproc, mpi, zenoh" in str(err.value)
    assert not out.exists()


def test_roles_under_mpirun(no_mpi_env):
    no_mpi_env.setenv("OMPI_COMM_WORLD_SIZE", "2")
    with pytest.raises(ValueError, match="--transport inproc runs the whole"):
        participant_role("inproc", None)
    with pytest.raises(ValueError, match="--transport zenoh without --participant"):
        participant_role("zenoh", None)
    # one program per participant (MPMD) is fine, whatever carries the messages
    assert participant_role("zenoh", "structure") == "structure"


def test_roles_without_mpirun(no_mpi_env):
    assert participant_role("inproc", None) is None
    assert participant_role("zenoh", None) == "fluid"
    assert participant_role("zenoh", "structure") == "structure"
    with pytest.raises(ValueError, match="--participant needs --transport mpi or zenoh"):
        participant_role("inproc", "fluid")


def test_structure_serves_on_through_sigterm_and_restores_the_handlers():
    """The serve loop under deferred_signals: a SIGTERM in the middle of the fluid's requests is
    noted and logged, the loop answers on until the fluid finalises (under mpirun the fluid got
    the same signal and stops cleanly at its window end), then the handlers are back."""
    fluid, structure = mock.pair(1.0)
    a, b = InprocTransport.pair(timeout_s=5.0)
    answers, logged = [], []

    def client():
        a.connect()
        remote = RemoteParticipant(a)
        answers.append(remote.read("displacement"))
        os.kill(os.getpid(), signal.SIGTERM)
        time.sleep(0.05)
        remote.write("forces", np.zeros_like(answers[0]))
        remote.advance(1e-3)
        answers.append(remote.read("displacement"))
        remote.finalize()

    before = {s: signal.getsignal(s) for s in (signal.SIGTERM, signal.SIGINT)}
    th = threading.Thread(target=client, daemon=True)
    th.start()
    b.connect()
    with deferred_signals(logged.append) as received:
        n = serve(structure, b)
    th.join(5.0)
    assert received == ["SIGTERM"] and n == 5 and len(answers) == 2
    assert "SIGTERM received; serving on until the fluid participant" in logged[0]
    assert {s: signal.getsignal(s) for s in before} == before


def test_a_second_signal_is_delivered():
    """Sent again, the signal takes its normal course (a stuck structure can still be ended).
    The normal course is Python's KeyboardInterrupt, set here: a process started in the
    background of a non-interactive shell inherits SIGINT ignored, and then the course it
    restores is to ignore it."""
    logged = []
    inherited = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        with pytest.raises(KeyboardInterrupt):
            with deferred_signals(logged.append) as received:
                signal.raise_signal(signal.SIGINT)
                assert received == ["SIGINT"]
                signal.raise_signal(signal.SIGINT)
        assert len(logged) == 1
        assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
    finally:
        signal.signal(signal.SIGINT, inherited)
