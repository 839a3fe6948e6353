"""Crafted checkpoints (issue 22): every array and number read from a file is checked before use.

A checkpoint whose AMG indices held 1e9 reached numba unchecked and crashed the process with a
segmentation fault; t = nan or t < 0 ran; a tiny file declaring a huge array ran out of memory;
external links were followed. Each is now refused as ``error: ...`` with exit code 2.
"""

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np
import pytest

from mpsfem.cli import main
from mpsfem.results.checkpoint import CheckpointError, read_checkpoint

ROOT = Path(__file__).resolve().parents[2]
DAM = ROOT / "scenarios" / "dam_break_2d.toml"


@pytest.fixture(scope="module")
def good(tmp_path_factory) -> tuple[Path, Path]:
    """(results, checkpoint) of three dam-break steps: the checkpoint holds an AMG hierarchy."""
    folder = tmp_path_factory.mktemp("ckpt")
    out = folder / "d.h5"
    assert main(["run", str(DAM), "--end-time", "0.003", "--out", str(out), "--no-progress"]) == 0
    ckpt = folder / "d.ckpt.h5"
    with h5py.File(ckpt) as h5:
        assert "L0_P_indices" in h5["fluid_preconditioner"]
    return out, ckpt


def crafted(good, tmp_path, edit) -> tuple[Path, Path]:
    """Copies of the good run's files, the checkpoint changed by ``edit(h5)``."""
    out, ckpt = (tmp_path / p.name for p in good)
    for src, dst in zip(good, (out, ckpt), strict=True):
        shutil.copy(src, dst)
    with h5py.File(ckpt, "r+") as h5:
        edit(h5)
    return out, ckpt


def replace(h5, name, data) -> None:
    del h5[name]
    h5.create_dataset(name, data=data)


def set_text(h5, name: str, text: str) -> None:
    replace(h5, f"_text/{name}", np.frombuffer(text.encode(), dtype=np.uint8))


def set_meta(h5, change) -> None:
    meta = json.loads(h5["_text/meta"][()].tobytes())
    change(meta)
    set_text(h5, "meta", json.dumps(meta))


def _string_format(h5):
    # a heap-stored (variable-length string) format: its type is refused before any value is read
    del h5.attrs["format"]
    h5.attrs["format"] = "2"


def _indices_1e9(h5):
    idx = h5["fluid_preconditioner/L0_P_indices"][()].astype(np.int64)
    idx[len(idx) // 2] = 10**9
    replace(h5, "fluid_preconditioner/L0_P_indices", idx)


def _indptr_scaled(h5):
    replace(h5, "fluid_preconditioner/L0_P_indptr", h5["fluid_preconditioner/L0_P_indptr"][()] * 7)


def _huge_declared(h5):
    del h5["fluid/p"]
    h5.create_dataset("fluid/p", shape=(10**10,), dtype="f8")  # no storage: a tiny file


def _external_link(h5):
    del h5["fluid/vel"]
    h5["fluid/vel"] = h5py.ExternalLink("/etc/passwd", "/vel")


def _nan_position(h5):
    pos = h5["fluid/pos"][()]
    pos[3, 1] = np.nan
    replace(h5, "fluid/pos", pos)


CASES = {
    "indices 1e9": (_indices_1e9, "L0_P_indices: column indices"),
    "indptr scaled": (_indptr_scaled, "L0_P_indptr: must start at 0, never decrease and end"),
    "t nan": (lambda h5: set_meta(h5, lambda m: m["fluid"].update(t=float("nan"))), "fluid.t"),
    "t negative": (lambda h5: set_meta(h5, lambda m: m["fluid"].update(t=-1.0)), "fluid.t = -1"),
    "huge declared shape": (_huge_declared, "fluid/p declares shape (10000000000,)"),
    "external link": (_external_link, "fluid/vel is a ExternalLink"),
    "nan position": (_nan_position, "fluid/pos holds a non-finite value at index [3, 1]"),
    "text array": (lambda h5: replace(h5, "fluid/p", np.array([b"x"])), "a number array"),
    "wrong shape": (lambda h5: replace(h5, "fluid/p", np.zeros(3)), "fluid/p has shape (3,)"),
    "no meta": (lambda h5: h5["_text"].__delitem__("meta"), "text 'meta' is missing"),
    "meta not json": (lambda h5: set_text(h5, "meta", "{"), "'meta' is not valid JSON"),
    "meta as floats": (lambda h5: replace(h5, "_text/meta", np.zeros(3)), "array of bytes"),
    "string format": (_string_format, "not a checkpoint of format 2"),
    "format 1": (lambda h5: h5.attrs.__setitem__("format", 1), "format 1 was written"),
    "dt_next zero": (
        lambda h5: set_meta(h5, lambda m: m["fluid"].update(dt_next=0.0)),
        "fluid.dt_next = 0.0",
    ),
    "sizes huge": (
        lambda h5: set_meta(h5, lambda m: m["fluid_preconditioner"].update(sizes=[10**12, 5])),
        "fluid_preconditioner.sizes[0] = 1000000000000 exceeds",
    ),
}


@pytest.mark.parametrize("case", list(CASES))
def test_crafted_checkpoint_is_refused_by_name(good, tmp_path, case):
    edit, expect = CASES[case]
    _, ckpt = crafted(good, tmp_path, edit)
    with pytest.raises(CheckpointError) as info:
        read_checkpoint(ckpt)
    assert expect in str(info.value)


def test_time_past_the_end_of_this_run_is_refused(good, tmp_path):
    _, ckpt = crafted(good, tmp_path, lambda h5: set_meta(h5, lambda m: m["fluid"].update(t=99.0)))
    with pytest.raises(CheckpointError, match="fluid.t = 99.0 lies past the end of this run"):
        read_checkpoint(ckpt, end_time=1.0)
    read_checkpoint(ckpt)  # continuing further (--end-time) is the caller's to say


def test_good_checkpoint_reads(good):
    arrays, meta, _ = read_checkpoint(good[1])
    assert meta["fluid"]["t"] == pytest.approx(0.003)
    assert arrays["fluid"]["pos"].shape[1] == 2


def test_restart_of_crafted_indices_exits_2_not_a_segfault(good, tmp_path):
    """End to end in a child process (a crash there cannot take the test run with it)."""
    out, ckpt = crafted(good, tmp_path, _indices_1e9)
    env = {**os.environ, "PYTHONPATH": str(ROOT / "src"), "NUMBA_NUM_THREADS": "1"}
    argv = [sys.executable, "-m", "mpsfem", "run", str(DAM), "--out", str(out)]
    argv += ["--restart", str(ckpt), "--no-progress"]
    proc = subprocess.run(argv, capture_output=True, text=True, env=env, timeout=300)
    assert proc.returncode == 2, proc.stderr[-2000:]
    assert proc.stderr.startswith("error: ") and "Traceback" not in proc.stderr
    assert "L0_P_indices" in proc.stderr
