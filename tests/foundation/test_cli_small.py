"""Small command-line faults of issue 22: what ``modes`` prints, where ``docs`` writes."""

from pathlib import Path

from mpsfem import cli
from mpsfem.cli import main

CANTILEVER = Path(__file__).resolve().parents[2] / "scenarios" / "structure_cantilever_demo.toml"


def test_modes_says_its_frequencies_are_dry(capsys):
    assert main(["modes", str(CANTILEVER), "--count", "2"]) == 0
    err = capsys.readouterr().err  # a note beside the table, which stays alone on stdout
    assert "note: dry (in vacuo) frequencies" in err and "without the fluid's added mass" in err


def test_docs_outside_a_source_checkout_needs_out(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(cli, "source_docs_path", lambda: None)
    assert main(["docs"]) == 2
    assert "give the file to write with --out PATH" in capsys.readouterr().err
    assert not (tmp_path / "docs").exists()


def test_docs_default_is_the_checkout_not_the_working_folder(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert (
        cli.source_docs_path() == Path(cli.__file__).resolve().parents[2] / "docs" / "scenarios.md"
    )
    assert not (tmp_path / "docs").exists()


def test_docs_out_folder_must_exist(tmp_path, capsys):
    assert main(["docs", "--out", str(tmp_path / "missing" / "s.md")]) == 2
    assert "does not exist" in capsys.readouterr().err
    assert not (tmp_path / "missing").exists()


def test_sigint_stops_the_run_with_a_reason_and_a_checkpoint(tmp_path):
    """Ctrl-C stops at the end of a step: status ``failed: interrupted (SIGINT)`` (it was
    ``failed: `` with no reason, or ``SystemError: CPUDispatcher(...)`` when it landed inside a
    numba call), a checkpoint of the last good state, exit code 1."""
    import os
    import signal
    import subprocess
    import sys
    import time

    import h5py

    root = Path(__file__).resolve().parents[2]
    out = tmp_path / "run.h5"
    ckpt = out.with_name("run.ckpt.h5")
    env = dict(os.environ, PYTHONPATH=str(root / "src"), PYTHONUNBUFFERED="1")
    sets = ["--set", "fluid.spacing=0.0073", "--set", "output.checkpoint_interval=0.02"]
    proc = subprocess.Popen(
        [sys.executable, "-m", "mpsfem", "run", str(root / "scenarios" / "dam_break_2d.toml")]
        + ["--out", str(out), "--end-time", "5", "--no-progress", *sets],
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        env=env,
    )
    deadline = time.monotonic() + 300
    while not ckpt.exists() and proc.poll() is None and time.monotonic() < deadline:
        time.sleep(0.05)
    time.sleep(0.3)
    proc.send_signal(signal.SIGINT)
    text, _ = proc.communicate(timeout=120)
    assert proc.returncode == 1, text
    assert "SystemError" not in text and "Traceback" not in text, text
    with h5py.File(out, "r") as h5:
        assert h5.attrs["status"] == "failed: interrupted (SIGINT)"
    assert ckpt.exists()


def test_own_warnings_print_as_one_warning_line():
    """mpsfem's warnings reach a CLI user as ``warning: ...`` lines (as ``error:`` / ``note:``),
    not as Python's ``file.py:123: Category: ...`` with the source line under it."""
    import subprocess
    import sys

    obstacle = CANTILEVER.parent / "dam_break_elastic_obstacle_2d.toml"
    proc = subprocess.run(
        [sys.executable, "-m", "mpsfem.cli", "validate", str(obstacle), "--set",
         "structure.members.0.material.density=2.43"],
        capture_output=True, text=True, timeout=300,
    )  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    lines = proc.stderr.splitlines()
    assert any(x.startswith("warning: structure member 'obstacle': mass ratio") for x in lines)
    assert "AddedMassWarning" not in proc.stderr and "schema.py" not in proc.stderr


def test_other_warnings_keep_pythons_form():
    import warnings

    cli.main(["docs", "--out", "/nonexistent-folder/s.md"])  # installs the format, exits 2
    text = warnings.formatwarning("plain", UserWarning, "f.py", 3)
    assert text.startswith("f.py:3: UserWarning: plain")
