"""A full disk stops a run cleanly: 'no space left' named, the results file readable with its
status set, the last checkpoint intact and no temporary file left (issue 22: it was a
segmentation fault with status 'running' and no checkpoint). The full disk is injected by
shrinking the free space the writes see (results/disk_space.py), so CI needs no mount."""

from __future__ import annotations

from pathlib import Path

import h5py
import pytest

from mpsfem.results import disk_space
from mpsfem.results.checkpoint import read_checkpoint, write_checkpoint
from mpsfem.scenario.loader import load_scenario
from mpsfem.simulation import RunFailed, run_fluid

ROOT = Path(__file__).resolve().parents[2]
SETS = [
    "fluid.spacing=0.0146",
    "output.snapshot_interval=0.002",
    "output.checkpoint_interval=0.01",
    "run.progress=false",
]


def fill_disk_after(monkeypatch, writes: int) -> list[int]:
    """The first ``writes`` space checks see a roomy disk, the rest a full one."""
    calls = [0]
    real = disk_space.free_bytes

    def free(path):
        calls[0] += 1
        return real(path) if calls[0] <= writes else 1024

    monkeypatch.setattr(disk_space, "free_bytes", free)
    return calls


def test_full_disk_stops_the_run_cleanly(tmp_path, monkeypatch):
    out = tmp_path / "db.h5"
    loaded = load_scenario(ROOT / "scenarios" / "dam_break_2d.toml", SETS)
    fill_disk_after(monkeypatch, 25)
    with pytest.raises(RunFailed, match="no space left") as err:
        run_fluid(loaded, out, end_time=0.05)
    msg = str(err.value)
    assert "results (readable" in msg and "earlier checkpoint" in msg
    with h5py.File(out, "r") as h5:  # readable, status set, snapshots intact
        assert h5.attrs["status"].startswith("failed: no space left")
        for key in h5["particles"]:
            assert h5["particles"][key]["pos"].shape[1] == 2
    ckpt = tmp_path / "db.ckpt.h5"
    _, meta, _ = read_checkpoint(ckpt)  # an interval checkpoint from before the disk filled
    t = meta["fluid"]["t"]
    assert 0.0 < t < 0.05 and t / 0.01 == pytest.approx(round(t / 0.01), abs=1e-6)
    assert not (tmp_path / "db.ckpt.h5.tmp").exists()


def test_checkpoint_refused_before_writing(tmp_path, monkeypatch):
    path = tmp_path / "c.ckpt.h5"
    write_checkpoint(path, {"fluid": {"x": [1.0, 2.0]}}, {"t": 0.0}, "title = 'x'")
    fill_disk_after(monkeypatch, 0)
    with pytest.raises(disk_space.DiskFullError, match="no space left for the checkpoint"):
        write_checkpoint(path, {"fluid": {"x": [3.0, 4.0]}}, {"t": 1.0}, "title = 'x'")
    assert not path.with_name(path.name + ".tmp").exists()
    with h5py.File(path, "r") as h5:  # the previous one is untouched
        assert h5["fluid"]["x"][:].tolist() == [1.0, 2.0]
