"""The same coupled case (mock participants, implicit IQN-ILS) gives bit-identical results on
every transport and launch form."""

from __future__ import annotations

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
