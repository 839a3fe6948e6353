"""File problems of the command line are refused before any compute, as `error: ...`, exit 2."""

from pathlib import Path

import h5py
import pytest

from mpsfem.cli import main, single_process_problem
from mpsfem.results.checkpoint import write_checkpoint
from mpsfem.results.results_file import ResultsFile

SCENARIOS = Path(__file__).resolve().parents[2] / "scenarios"
FLUID = SCENARIOS / "dam_break_2d.toml"
STRUCTURE = SCENARIOS / "structure_cantilever_demo.toml"


def error_of(capsys, argv: list[str]) -> str:
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: ") and "Traceback" not in err
    return err


def test_out_folder_must_exist(tmp_path, capsys):
    out = tmp_path / "missing" / "x.h5"
    err = error_of(capsys, ["run", str(FLUID), "--out", str(out)])
    assert f"--out {out}: the folder {out.parent} does not exist" in err
    err = error_of(capsys, ["structure", str(STRUCTURE), "--out", str(out)])
    assert f"the folder {out.parent} does not exist" in err


def test_restart_file_must_exist(tmp_path, capsys):
    ckpt = tmp_path / "nope.h5"
    err = error_of(
        capsys, ["run", str(FLUID), "--out", str(tmp_path / "r.h5"), "--restart", str(ckpt)]
    )
    assert f"--restart {ckpt}: no such checkpoint file" in err


def test_restart_needs_the_results_file_it_continues(tmp_path, capsys):
    ckpt = write_checkpoint(tmp_path / "c.ckpt.h5", {}, {}, "")
    out = tmp_path / "new.h5"
    err = error_of(capsys, ["run", str(FLUID), "--out", str(out), "--restart", str(ckpt)])
    assert "the results file does not exist" in err and str(out) in err
    assert not out.exists()  # no empty file left behind


def test_open_append_refuses_what_is_no_results_file(tmp_path):
    with pytest.raises(ValueError, match="does not exist"):
        ResultsFile.open_append(tmp_path / "none.h5")
    assert not (tmp_path / "none.h5").exists()
    empty = tmp_path / "empty.h5"
    empty.write_bytes(b"")
    with pytest.raises(ValueError, match="not a (readable HDF5 )?results file"):
        ResultsFile.open_append(empty)
    other = tmp_path / "other.h5"
    with h5py.File(other, "w") as h5:
        h5.create_group("probes")
    with pytest.raises(ValueError, match="no group particles, structure"):
        ResultsFile.open_append(other)


@pytest.mark.parametrize("count", ["0", "-2", "two"])
def test_modes_count_must_be_positive(capsys, count):
    with pytest.raises(SystemExit) as info:
        main(["modes", str(STRUCTURE), "--count", count])
    assert info.value.code == 2
    assert f"argument --count: '{count}': must be a whole number >= 1" in capsys.readouterr().err


@pytest.mark.parametrize("command, scenario", [("run", FLUID), ("structure", STRUCTURE)])
def test_one_process_runs_are_refused_under_mpirun(
    tmp_path, capsys, monkeypatch, command, scenario
):
    """``mpirun -n 2 mpsfem run <fluid-only>`` (or ``mpsfem structure``): every rank would run the
    whole simulation into the same file; refused before any compute, naming the rank count."""
    from mpsfem.coupler.launch import MPI_SIZE_VARIABLES

    for name in MPI_SIZE_VARIABLES:
        monkeypatch.delenv(name, raising=False)
    monkeypatch.setenv("OMPI_COMM_WORLD_SIZE", "2")
    out = tmp_path / "twice.h5"
    err = error_of(capsys, [command, str(scenario), "--out", str(out)])
    assert "one of 2 MPI ranks (OMPI_COMM_WORLD_SIZE=2)" in err
    assert "Start it without mpirun" in err
    assert not out.exists()
    monkeypatch.setenv("OMPI_COMM_WORLD_SIZE", "1")  # a job of one rank runs as usual
    assert single_process_problem("a run") is None
