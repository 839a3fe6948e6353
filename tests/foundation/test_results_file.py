"""The results-file contract: layout, attributes, incremental writing and truncation on restart."""

import os
import re
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np

from mpsfem import __version__
from mpsfem.results.checkpoint import read_checkpoint, write_checkpoint
from mpsfem.results.results_file import ResultsFile
from mpsfem.results.xdmf import write_xdmf


def test_layout_and_attributes(tmp_path):
    path = tmp_path / "r.h5"
    rf = ResultsFile.create(path, "title = 'x'", ["a.b=1"], {"a": {"b": 1}})
    rf.add_probe("g", "pressure", "Pa", (), position=[0.1, 0.2])
    rf.add_probe("f", "force", "N", ("fx", "fy"))
    for k in range(5):
        rf.append_probe("g", 0.1 * k, 10.0 * k)
        rf.append_probe("f", 0.1 * k, [k, -k])
    rf.add_structure("plate", np.zeros((3, 2)))
    rf.append_structure("plate", 0.0, np.ones((3, 2)))
    rf.write_snapshot(0.0, np.zeros((4, 2)), np.ones((4, 2)), np.arange(4.0), np.zeros(4, np.int8))
    rf.append_coupling(0.1, 3, 1e-5, work=1.0)
    rf.close("finished")
    with h5py.File(path, "r") as h5:
        assert h5.attrs["version"] == __version__
        assert h5.attrs["scenario"] == "title = 'x'"
        assert h5.attrs["status"] == "finished"
        assert h5.attrs["wall_time"] >= 0.0
        g = h5["probes/g"]
        assert g.attrs["kind"] == "pressure" and g.attrs["unit"] == "Pa"
        np.testing.assert_array_equal(g.attrs["position"], [0.1, 0.2])
        np.testing.assert_allclose(g["value"][:], 10.0 * np.arange(5))
        assert list(h5["probes/f"].attrs["components"]) == ["fx", "fy"]
        assert h5["probes/f/value"].shape == (5, 2)
        assert h5["structure/plate/displacement"].shape == (1, 3, 2)
        snap = h5["particles/000000"]
        assert snap.attrs["time"] == 0.0 and snap["pos"].shape == (4, 2)
        assert h5["coupling/iterations"][0] == 3


def test_truncate_after_for_restart(tmp_path):
    path = tmp_path / "r.h5"
    rf = ResultsFile.create(path, "", [])
    rf.add_probe("g", "pressure", "Pa")
    for k in range(10):
        rf.append_probe("g", float(k), float(k))
        if k % 3 == 0:
            rf.write_snapshot(
                float(k), np.zeros((1, 2)), np.zeros((1, 2)), np.zeros(1), np.zeros(1, np.int8)
            )
    rf.close()
    rf = ResultsFile.open_append(path, truncate_after=4.0)
    assert rf.n_snapshots == 2
    rf.append_probe("g", 5.0, -1.0)
    rf.close()
    with h5py.File(path, "r") as h5:
        np.testing.assert_array_equal(h5["probes/g/time"][:], [0, 1, 2, 3, 4, 5])
        assert sorted(h5["particles"]) == ["000000", "000001"]


def test_checkpoint_roundtrip(tmp_path):
    arrays = {"fluid": {"pos": np.random.default_rng(0).random((5, 2))}}
    meta = {
        "fluid": {"t": 1.5, "step": 3, "dt_next": 1e-3},
        "next_snapshot": 1.6,
        "next_checkpoint": float("inf"),
    }
    path = write_checkpoint(tmp_path / "c.ckpt.h5", arrays, meta, "text")
    got, got_meta, text = read_checkpoint(path)
    np.testing.assert_array_equal(got["fluid"]["pos"], arrays["fluid"]["pos"])
    assert got_meta == meta and text == "text"


def test_xdmf_lists_snapshots(tmp_path):
    path = tmp_path / "r.h5"
    rf = ResultsFile.create(path, "", [])
    for k in range(3):
        rf.write_snapshot(
            0.5 * k, np.zeros((2, 2)), np.zeros((2, 2)), np.zeros(2), np.zeros(2, np.int8)
        )
    out = write_xdmf(rf.h5, tmp_path / "r.xdmf")
    rf.close()
    text = out.read_text()
    assert text.count('<Grid Name="0000') == 3
    assert "r.h5:/particles/000002/pos" in text and 'Time Value="1.0"' in text


def _snapshot(rf: ResultsFile, t: float) -> None:
    rf.write_snapshot(t, np.zeros((2, 2)), np.zeros((2, 2)), np.zeros(2), np.zeros(2, np.int8))


def _sidecar_keys(path) -> list[str]:
    return re.findall(r'<Grid Name="(\d+)" GridType="Uniform">', path.read_text())


def test_xdmf_sidecar_follows_the_flushed_file(tmp_path):
    """The sidecar is rewritten when the file is flushed, never ahead of it; a restart's
    truncation rewrites it; a new run removes a stale one."""
    path, side = tmp_path / "r.h5", tmp_path / "r.xdmf"
    side.write_text("stale")
    rf = ResultsFile.create(path, "", [], xdmf=side)
    assert not side.exists()
    for k in range(3):
        _snapshot(rf, 0.5 * k)
    assert not side.exists()  # not flushed yet
    rf.flush()
    assert _sidecar_keys(side) == ["000000", "000001", "000002"]
    _snapshot(rf, 1.5)
    assert len(_sidecar_keys(side)) == 3
    rf.close()
    assert len(_sidecar_keys(side)) == 4
    rf = ResultsFile.open_append(path, truncate_after=0.6, xdmf=side)
    assert _sidecar_keys(side) == ["000000", "000001"]
    rf.close()


KILL_AFTER_SNAPSHOT = """
import os, sys
from pathlib import Path
import mpsfem.simulation as sim
from mpsfem.results.results_file import ResultsFile
from mpsfem.scenario.loader import load_scenario

written = []
original = ResultsFile.write_snapshot

def write_snapshot(self, *args):
    key = original(self, *args)
    written.append(key)
    if len(written) == 2:
        self.flush()  # as the wall-clock flush would
    return key

def update(self, t, dt):  # the step after the third snapshot: killed
    if len(written) >= 3:
        os._exit(9)

ResultsFile.write_snapshot = write_snapshot
sim.Progress.update = update
sets = ["fluid.spacing=0.0146", "output.snapshot_interval=1e-6", "output.flush_interval=1e6",
        "output.checkpoint_interval=0", "run.threads=1"]
loaded = load_scenario(sys.argv[1], sets)
sim.run_fluid(loaded, Path(sys.argv[2]), 0.05, progress=False)
"""


def test_killed_run_leaves_a_sidecar_listing_only_snapshots_on_disk(tmp_path):
    out = tmp_path / "k.h5"
    scene = Path(__file__).resolve().parents[2] / "scenarios" / "dam_break_2d.toml"
    env = dict(os.environ, NUMBA_NUM_THREADS="1")
    proc = subprocess.run(
        [sys.executable, "-c", KILL_AFTER_SNAPSHOT, str(scene), str(out)],
        capture_output=True,
        text=True,
        env=env,
        timeout=300,
    )
    assert proc.returncode == 9, proc.stderr
    with h5py.File(out, "r") as h5:
        on_disk = sorted(h5["particles"])
    listed = _sidecar_keys(tmp_path / "k.xdmf")
    assert listed and set(listed) <= set(on_disk), (listed, on_disk)


def test_coupling_rows_keep_one_row_per_window_across_flushes(tmp_path):
    """/coupling is buffered and written at each flush: a key first seen after a flush is
    NaN-padded for the windows written before it, a key a window lacks reads NaN there, and the
    buffered rows reach the file at close."""
    path = tmp_path / "c.h5"
    rf = ResultsFile.create(path, "title = 'x'")
    rf.append_coupling(0.1, 1, 1e-3, a=1.0)
    rf.flush()
    rf.append_coupling(0.2, 2, 1e-4, a=2.0, b=5.0)
    rf.append_coupling(0.3, 3, 1e-5)
    rf.flush()
    rf.append_coupling(0.4, 4, 1e-6, b=7.0)
    rf.close("finished")
    with h5py.File(path, "r") as h5:
        g = h5["coupling"]
        np.testing.assert_allclose(g["time"][:], [0.1, 0.2, 0.3, 0.4])
        np.testing.assert_array_equal(g["iterations"][:], [1, 2, 3, 4])
        assert g["iterations"].dtype == np.int32
        np.testing.assert_allclose(g["residual"][:], [1e-3, 1e-4, 1e-5, 1e-6])
        np.testing.assert_array_equal(g["a"][:], [1.0, 2.0, np.nan, np.nan])
        np.testing.assert_array_equal(g["b"][:], [np.nan, 5.0, np.nan, 7.0])
