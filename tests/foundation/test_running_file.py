"""Reading a results file while a run writes it, and a restart's truncation of a series that a
killed append left unsorted (issue 22)."""

from __future__ import annotations

import subprocess
import sys

import h5py
import numpy as np

from mpsfem.results.results_file import ResultsFile, _rows_up_to
from mpsfem.tools.results_series import open_results


def test_a_running_file_opens_for_reading(tmp_path):
    path = tmp_path / "run.h5"
    writer = ResultsFile.create(path, "title = 'x'")
    writer.add_probe("p", "pressure", "Pa")
    for k in range(5):
        writer.append_probe("p", 0.1 * k, float(k))
    writer.flush()  # what a reader sees: the last flush
    writer.append_probe("p", 0.5, 5.0)  # buffered, not yet on disk
    reader = (  # another process, as `mpsfem plot` would be
        "import sys; from mpsfem.tools.results_series import open_results\n"
        "h5 = open_results(sys.argv[1]); print(h5.attrs['status'], h5['probes/p/value'][:].tolist())"
    )
    try:
        got = subprocess.run(
            [sys.executable, "-c", reader, str(path)], capture_output=True, text=True, timeout=60
        )
    finally:
        writer.close("finished")
    assert got.returncode == 0, got.stderr
    assert got.stdout.split(None, 1) == ["running", "[0.0, 1.0, 2.0, 3.0, 4.0]\n"]
    with open_results(path) as h5:
        assert h5["probes/p/value"].shape == (6,)


def test_truncation_stops_at_an_unwritten_row():
    """A resize that a kill interrupted before its write leaves a row of zeros: a restart at
    t = 0.4 keeps the rows before it (searchsorted on the unsorted times kept all five)."""
    times = np.array([0.1, 0.2, 0.3, 0.0, 0.0])
    assert _rows_up_to(times, 0.4) == 3
    assert _rows_up_to(times, 0.25) == 2
    assert _rows_up_to(np.array([0.1, 0.2, 0.3]), 0.2) == 2
    assert _rows_up_to(np.array([]), 1.0) == 0


def test_restart_drops_a_half_appended_coupling_row(tmp_path):
    """Fault injection: an append resized /coupling and was stopped before its write (the
    Ctrl-C'd zenoh run of issue 22), leaving a zero row; a restart at the checkpoint time keeps
    the rows up to it and no zero row (searchsorted on the unsorted times kept the zero row)."""
    path = tmp_path / "c.h5"
    f = ResultsFile.create(path, "title = 'x'")
    for k in range(1, 5):
        f.append_coupling(k / 10, 2, 1e-4)
    f.flush()  # the rows reach the file at a flush
    for ds in f.h5["coupling"].values():  # the interrupted append: resized, never written
        ds.resize(ds.shape[0] + 1, axis=0)
    f.close("failed: interrupted (SIGINT)")
    f = ResultsFile.open_append(path, truncate_after=0.3)
    f.append_coupling(0.4, 2, 1e-4)
    f.close("finished")
    with h5py.File(path, "r") as h5:
        np.testing.assert_allclose(h5["coupling/time"][:], [0.1, 0.2, 0.3, 0.4])
        assert (h5["coupling/iterations"][:] == 2).all()
