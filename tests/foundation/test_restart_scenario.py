"""A restart continues only the physics its checkpoint ran; output and run control may change."""

import json
from pathlib import Path

import h5py
import numpy as np
import pytest

from mpsfem.cli import main
from mpsfem.scenario.compare import restart_differences
from mpsfem.scenario.loader import load_scenario
from mpsfem.simulation import run_fluid

SCENE = Path(__file__).resolve().parents[2] / "scenarios" / "dam_break_2d.toml"
COARSE = ["fluid.spacing=0.0146", "run.threads=1", "output.checkpoint_interval=0"]
END = 0.004


def test_differences_skip_run_output_and_sampling():
    a = {
        "run": {"end_time": 1.0},
        "output": {"xdmf": True},
        "fluid": {"spacing": 0.01, "blocks": [{"lower": [0.0, 0.0]}]},
        "probes": [{"name": "g", "interval": 0.1, "position": [0.1, 0.1]}],
    }
    b = {
        "run": {"end_time": 2.0},
        "output": {"xdmf": False},
        "fluid": {"spacing": 0.02, "blocks": [{"lower": [0.0, 0.0]}, {"lower": [1.0, 0.0]}]},
        "probes": [{"name": "g", "interval": 0.2, "position": [0.1, 0.2]}],
    }
    assert restart_differences(a, b) == [
        ("fluid.blocks (items)", 1, 2),
        ("fluid.blocks[1].lower", "(absent)", [1.0, 0.0]),
        ("fluid.spacing", 0.01, 0.02),
        ("probes[0].position", [0.1, 0.1], [0.1, 0.2]),
    ]


@pytest.fixture(scope="module")
def first_run(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("first") / "r.h5"
    run_fluid(load_scenario(SCENE, COARSE), out, END, progress=False, log=lambda m: None)
    return out


def _copy(first: Path, folder: Path) -> tuple[Path, Path]:
    out, ckpt = folder / "r.h5", folder / "r.ckpt.h5"
    out.write_bytes(first.read_bytes())
    ckpt.write_bytes(first.with_name("r.ckpt.h5").read_bytes())
    return out, ckpt


def test_restart_with_other_physics_is_refused_naming_keys_and_values(first_run, tmp_path, capsys):
    out, ckpt = _copy(first_run, tmp_path)
    sets = [a for s in [*COARSE, "fluid.density=998.0"] for a in ("--set", s)]
    argv = ["run", str(SCENE), "--out", str(out), "--restart", str(ckpt), "--end-time", "0.008"]
    assert main([*argv, *sets]) == 2
    err = capsys.readouterr().err
    assert "the scenario differs from the one the checkpoint ran" in err
    assert "fluid.density: checkpoint 1000.0, now 998.0" in err
    with h5py.File(out, "r") as h5:  # untouched
        assert h5.attrs["status"] == "finished" and "restarts" not in h5.attrs


def test_restart_may_change_output_and_is_recorded(first_run, tmp_path):
    out, ckpt = _copy(first_run, tmp_path)
    sets = [*COARSE, "output.snapshot_interval=0.001", "probes.0.interval=0.0005"]
    run_fluid(load_scenario(SCENE, sets), out, 2 * END, ckpt, progress=False, log=lambda m: None)
    with h5py.File(out, "r") as h5:
        assert h5.attrs["status"] == "finished"
        (rec,) = json.loads(h5.attrs["restarts"])
        assert rec["overrides"] == sets and rec["checkpoint"] == str(ckpt)
        assert rec["time"] == pytest.approx(END)


def test_old_checkpoint_without_resolved_scenario_is_accepted_with_a_warning(first_run, tmp_path):
    out, ckpt = _copy(first_run, tmp_path)
    with h5py.File(ckpt, "a") as h5:
        del h5["_text/scenario_resolved"]
        del h5["_text/overrides"]
        del h5["_text/scenario"]
        h5["_text"].create_dataset("scenario", data=np.frombuffer(b"an older text", np.uint8))
    logged: list[str] = []
    run_fluid(load_scenario(SCENE, COARSE), out, 2 * END, ckpt, progress=False, log=logged.append)
    assert any("predates storing the resolved scenario" in m for m in logged)


def _drop_keys_from_checkpoint(ckpt: Path, section: str, keys: list[str]) -> None:
    """Make ``ckpt`` look like one written before ``keys`` of ``section`` existed."""
    with h5py.File(ckpt, "a") as h5:
        resolved = json.loads(bytes(h5["_text/scenario_resolved"][()]).decode())
        table = resolved
        for part in section.split("."):
            table = table[part]
        for key in keys:
            del table[key]
        del h5["_text/scenario_resolved"]
        data = np.frombuffer(json.dumps(resolved).encode(), np.uint8)
        h5["_text"].create_dataset("scenario_resolved", data=data)


def test_a_checkpoint_predating_new_keys_continues_at_their_defaults(first_run, tmp_path):
    """Keys added since the checkpoint was written take this version's defaults (which keep
    the earlier behaviour); the restart goes on with a note naming them."""
    out, ckpt = _copy(first_run, tmp_path)
    _drop_keys_from_checkpoint(ckpt, "fluid.pressure", ["error_compensation", "source_term"])
    logged: list[str] = []
    run_fluid(load_scenario(SCENE, COARSE), out, 2 * END, ckpt, progress=False, log=logged.append)
    (note,) = [m for m in logged if "predates the keys" in m]
    assert "fluid.pressure.error_compensation" in note and "fluid.pressure.source_term" in note
    with h5py.File(out, "r") as h5:
        assert h5.attrs["status"] == "finished"


def test_a_new_key_set_away_from_its_default_is_still_refused(first_run, tmp_path, capsys):
    out, ckpt = _copy(first_run, tmp_path)
    _drop_keys_from_checkpoint(ckpt, "fluid.pressure", ["error_compensation", "source_term"])
    sets = [a for s in [*COARSE, "fluid.pressure.error_compensation=true"] for a in ("--set", s)]
    argv = ["run", str(SCENE), "--out", str(out), "--restart", str(ckpt), "--end-time", "0.008"]
    assert main([*argv, *sets]) == 2
    err = capsys.readouterr().err
    assert "fluid.pressure.error_compensation: checkpoint '(absent)', now True" in err


def test_at_schema_default_reads_the_field_default_through_tables_and_lists():
    from mpsfem.scenario.compare import at_schema_default

    m = load_scenario(
        Path(__file__).resolve().parents[2] / "scenarios" / "bottom_slamming_elastic_2d.toml"
    ).scenario
    assert at_schema_default(m, "fluid.pressure.error_compensation", False)
    assert not at_schema_default(m, "fluid.pressure.error_compensation", True)
    assert at_schema_default(m, "fluid.pressure.gradient", "corrected_pmin")
    assert at_schema_default(m, "structure.members[0].kinematics", "linear")
    assert not at_schema_default(m, "structure.members[5].kinematics", "linear")  # no member 5
    assert not at_schema_default(m, "fluid.no_such_key", 1)
    assert not at_schema_default(m, "fluid.spacing", m.fluid.spacing)  # required: no default
