"""The results-file contract: layout, attributes, incremental writing and truncation on restart."""

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
    path = write_checkpoint(tmp_path / "c.ckpt.h5", arrays, {"t": 1.5}, "text")
    got, meta, text = read_checkpoint(path)
    np.testing.assert_array_equal(got["fluid"]["pos"], arrays["fluid"]["pos"])
    assert meta == {"t": 1.5} and text == "text"


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
