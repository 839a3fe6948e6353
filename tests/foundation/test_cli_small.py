"""Small command-line faults of issue 22: what ``modes`` prints, where ``docs`` writes."""

from pathlib import Path

from mpsfem import cli
from mpsfem.cli import main

CANTILEVER = Path(__file__).resolve().parents[2] / "scenarios" / "structure_cantilever_demo.toml"


def test_modes_says_its_frequencies_are_dry(capsys):
    assert main(["modes", str(CANTILEVER), "--count", "2"]) == 0
    out = capsys.readouterr().out
    assert "dry (in vacuo) frequencies" in out and "without the fluid's added mass" in out


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
