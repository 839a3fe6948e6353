"""`mpsfem sweep` on the structure-only cantilever (each case well under a second): grid
parsing, validation before any case starts, child runs, summary peaks against the results files,
resumption, a failing case."""

import contextlib
import csv
import io
import json
import math
import tomllib
from pathlib import Path

import h5py
import numpy as np
import pytest

from mpsfem.cli import main
from mpsfem.scenario.base import ScenarioError
from mpsfem.tools.grid import make_cases, parse_grid_arg, short_keys, split_literals, toml_literal
from mpsfem.tools.peaks import PeakSpec, peak_of
from mpsfem.tools.results_series import Series
from mpsfem.tools.sweep import choose_jobs, completed, plan_sweep

ROOT = Path(__file__).resolve().parents[2]
CANTILEVER = ROOT / "scenarios" / "structure_cantilever_demo.toml"
THICKNESS = "structure.members.0.thickness=0.01,0.02"
FORCE = "structure.loads.0.force=[0.0, -100.0],[0.0,-2e2]"
END = "0.05"  # s: past the first peak of the thick beam (T1/2 = 0.03 s), not of the thin one


def _sweep(*args: str) -> tuple[int, str, str]:
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        rc = main(["sweep", str(CANTILEVER), *args])
    return rc, out.getvalue(), err.getvalue()


def _rows(folder: Path) -> list[dict]:
    with open(folder / "summary.csv", newline="") as fh:
        return list(csv.DictReader(fh))


@pytest.fixture(scope="module")
def grid_sweep(tmp_path_factory):
    """The 2 x 2 sweep, run once for the module, two cases at a time."""
    folder = tmp_path_factory.mktemp("sweep") / "out"
    args = ["--grid", THICKNESS, "--grid", FORCE, "--jobs", "2", "--end-time", END]
    args += ["--peak", "tip:uy", "energy", "--out", str(folder)]
    rc, out, err = _sweep(*args)
    return folder, args, rc, out, err


# ------------------------------------------------------------------------------ grid parsing


def test_split_and_literals():
    assert split_literals('1, [2, 3], "a,b", {x = 1, y = [2]}') == [
        "1",
        "[2, 3]",
        '"a,b"',
        "{x = 1, y = [2]}",
    ]
    for value in (0.01, 1e-5, -3, True, 'imp"licit', [0.0, -1e2], {"kind": "step", "t": 0.5}):
        assert tomllib.loads(f"v = {toml_literal(value)}")["v"] == value
    assert toml_literal(float("inf")) == "inf"


def test_cases_are_named_deterministically():
    axes = [parse_grid_arg(THICKNESS), parse_grid_arg(FORCE)]
    cases = make_cases(axes)
    assert [c.label for c in cases] == [
        "thickness=0.01 force=[0.0, -100.0]",
        "thickness=0.01 force=[0.0, -200.0]",
        "thickness=0.02 force=[0.0, -100.0]",
        "thickness=0.02 force=[0.0, -200.0]",
    ]
    assert cases[3].overrides() == [
        "structure.members.0.thickness=0.02",
        "structure.loads.0.force=[0.0, -200.0]",
    ]
    names = [c.name for c in cases]
    assert len(set(names)) == 4 and names == [c.name for c in make_cases(axes)]
    assert names[0].startswith("thickness=0.01__force=_0.0_-100.0_-")  # "[,]" unsafe: hashed
    # 1e-2 and 0.01 are one value, hence one case name
    assert make_cases([parse_grid_arg("a.b=1e-2")])[0].name == "b=0.01"
    assert make_cases([parse_grid_arg('coupling.scheme="implicit"')])[0].name == "scheme=implicit"
    # bare words as for --set (a shell strips the quotes); they hold no comma, so split cleanly
    bare = parse_grid_arg("coupling.scheme=implicit,explicit")
    assert bare.values == ("implicit", "explicit") and not bare.numeric
    assert bare.literals == ('"implicit"', '"explicit"')
    assert parse_grid_arg("a.b=true,inf").values == (True, math.inf)  # TOML literals stay so
    assert short_keys(["a.x.k", "b.x.k", "c.m"]) == {"a.x.k": "a.x.k", "b.x.k": "b.x.k", "c.m": "m"}


def test_choose_jobs():
    assert choose_jobs(None, 4, 8) == (4, 2)
    assert choose_jobs(None, 10, 2) == (1, 2)
    assert choose_jobs(3, 2, 16) == (2, 8)  # never more jobs than cases
    assert choose_jobs(4, 9, 2) == (4, 1)


def test_peak_of_a_sampled_sine():
    """max |A sin(w t)| on a grid holding t = pi / (2 w): A, at that time; magnitude when no
    component is named; NaN samples skipped."""
    t = np.linspace(0.0, 1.0, 401)  # holds t = 0.125 and 0.375
    vals = np.column_stack([3.0 * np.sin(4 * np.pi * t), 4.0 * np.sin(4 * np.pi * t)])
    vals[0, 0] = np.nan
    s = Series("f", "f", t, vals, ["fx", "fy"], ["N", "N"])
    p = peak_of(s, "fy")
    assert p.value == pytest.approx(4.0, rel=1e-15) and p.time == pytest.approx(0.125)
    assert peak_of(s, "fx").value == pytest.approx(3.0, rel=1e-15)
    assert peak_of(s).value == pytest.approx(5.0, rel=1e-15)  # sqrt(3^2 + 4^2)
    assert math.isnan(peak_of(Series("g", "g", t[:2], np.full((2, 1), np.nan), ["v"], [""])).value)


# ------------------------------------------------------------------- validation before runs


def test_bad_grid_rejected_before_any_case(tmp_path):
    folder = tmp_path / "out"
    rc, out, err = _sweep("--grid", "structure.members.0.thicknes=0.01,0.02", "--out", str(folder))
    assert rc == 2 and out == ""
    assert "structure.members[0].thicknes: unknown key; allowed here:" in err
    assert "thickness" in err and not folder.exists()
    rc, _, err = _sweep("--grid", "structure.members.0.thickness=0.01,-0.02", "--out", str(folder))
    assert rc == 2 and "structure.members[0].thickness = -0.02" in err
    assert "[case thickness=-0.02]" in err and not folder.exists()
    rc, _, err = _sweep("--grid", "coupling.scheme=implicit,1/2", "--out", str(folder))
    assert rc == 2 and "--grid coupling.scheme = '1/2': not a TOML literal" in err
    rc, _, err = _sweep("--grid", THICKNESS, "--set", "structure.members.0.thickness=0.03")
    assert rc == 2 and "also given by --set" in err
    rc, _, err = _sweep("--grid", THICKNESS, "--end-time", "1", "--set", "run.end_time=2")
    assert rc == 2 and "give the end time once" in err
    rc, _, err = _sweep("--grid", "run.end_time=0.1,0.2", "--end-time", "1")
    assert rc == 2 and "--grid run.end_time: also given by --end-time" in err
    rc, _, err = _sweep("--grid", THICKNESS, "--peak", "tip:uz", "--out", str(folder))
    assert rc == 2 and "--peak tip:uz: probe 'tip' has components ux, uy" in err
    rc, _, err = _sweep("--grid", THICKNESS, "--peak", "tipp", "--out", str(folder))
    assert rc == 2 and "no probe 'tipp' (tip, energy)" in err
    assert not folder.exists()


# ------------------------------------------------------------------------------- the runs


def test_summary_peaks_match_the_results_files(grid_sweep):
    folder, _, rc, out, err = grid_sweep
    assert rc == 0, out + err
    rows = _rows(folder)
    assert [r["status"] for r in rows] == ["finished"] * 4
    assert [r["structure.members.0.thickness"] for r in rows] == ["0.01", "0.01", "0.02", "0.02"]
    assert out.count(" start ") == 4 and out.count(" done ") == 4
    assert "2 at a time" in out
    for r in rows:
        with h5py.File(folder / r["case"] / "results.h5", "r") as h5:
            assert h5.attrs["status"] == "finished"
            assert json.loads(h5.attrs["overrides"])[0] == f"run.end_time={float(END)!r}"
            t = h5["probes/tip/time"][:]
            uy = np.abs(h5["probes/tip/value"][:, 1])
            e = np.linalg.norm(h5["probes/energy/value"][:], axis=1)
            assert t[-1] == pytest.approx(float(END))
        assert float(r["peak[tip:uy]"]) == uy.max()
        assert float(r["t_peak[tip:uy]"]) == t[np.argmax(uy)]
        assert float(r["peak[energy]"]) == e.max()
        assert float(r["wall_time_s"]) > float(r["run_wall_time_s"]) > 0
        record = json.loads((folder / r["case"] / "case.json").read_text())
        assert record["status"] == "finished" and record["returncode"] == 0
    # the grid reached the children: a linear structure's response scales with the load
    for a, b in ((0, 1), (2, 3)):
        assert float(rows[b]["peak[tip:uy]"]) == pytest.approx(
            2 * float(rows[a]["peak[tip:uy]"]), rel=1e-9
        )
        assert rows[b]["t_peak[tip:uy]"] == rows[a]["t_peak[tip:uy]"]
    # and the thickness too: 8x stiffer, 2x heavier, so the thick beam peaks earlier and less
    assert float(rows[2]["peak[tip:uy]"]) < 0.2 * float(rows[0]["peak[tip:uy]"])
    plots = sorted(p.name for p in folder.glob("peak-*.png"))
    assert plots == [
        "peak-energy-vs-force.png",
        "peak-energy-vs-thickness.png",
        "peak-tip-uy-vs-force.png",
        "peak-tip-uy-vs-thickness.png",
    ]
    assert all(p.read_bytes()[:4] == b"\x89PNG" for p in folder.glob("peak-*.png"))


def test_second_invocation_runs_nothing(grid_sweep):
    folder, args, *_ = grid_sweep
    results = sorted(folder.glob("*/results.h5"))
    before = {p: p.stat().st_mtime_ns for p in results}
    rc, out, err = _sweep(*args)
    assert rc == 0, out + err
    assert "0 to run, 4 complete" in out and out.count(" reused ") == 4
    assert " start " not in out
    assert {p: p.stat().st_mtime_ns for p in results} == before
    assert [r["reused"] for r in _rows(folder)] == ["yes"] * 4
    # other options make other results: nothing counts as complete then
    plan = plan_sweep(CANTILEVER, [THICKNESS, FORCE], out_dir=folder, end_time=0.04)
    ok, why, _ = completed(plan, plan.cases[0])
    assert not ok and why == "scenario or options changed since"
    plan = plan_sweep(CANTILEVER, [THICKNESS, FORCE], out_dir=folder, end_time=float(END))
    assert completed(plan, plan.cases[0])[0]


def test_failing_case_is_reported_and_the_others_finish(tmp_path):
    folder = tmp_path / "out"
    # a load too large for float64 arithmetic passes validation and fails at run time
    force = "structure.loads.0.force=[0.0, 1e308],[0.0, -100.0]"
    args = ["--grid", force, "--end-time", "0.01", "--peak", "tip", "--jobs", "2"]
    rc, out, err = _sweep(*args, "--out", str(folder))
    assert rc == 1
    rows = _rows(folder)
    assert [r["status"] for r in rows] == ["failed", "finished"]
    assert "structure state not finite" in rows[0]["error"]  # the overflow caught in the run
    assert rows[0]["peak[tip]"] == "" and float(rows[1]["peak[tip]"]) > 0
    assert "[1/2] FAILED  force=[0.0, 1e+308]: exit 1" in out
    assert "1 finished (0 reused), 1 failed" in out
    record = json.loads((folder / rows[0]["case"] / "case.json").read_text())
    assert record["status"] == "failed" and record["returncode"] == 1
    # the failed case is tried again, the finished one is not
    rc, out, _ = _sweep(*args, "--out", str(folder))
    assert rc == 1 and "1 to run, 1 complete" in out and "[1/2] rerun   force=[0.0, 1e+308]" in out


@pytest.mark.parametrize("end", [0.0, -1.0, float("inf"), float("nan")])
def test_end_time_must_be_finite_and_positive(end):
    with pytest.raises(ScenarioError, match="--end-time = .*must be finite and > 0"):
        plan_sweep(CANTILEVER, [THICKNESS], end_time=end)


def test_plan_validates_every_case():
    with pytest.raises(ScenarioError, match="given more than once"):
        plan_sweep(CANTILEVER, [THICKNESS, THICKNESS])
    plan = plan_sweep(CANTILEVER, [THICKNESS], peaks=["tip:uy"], overrides=["run.end_time=0.2"])
    assert plan.subcommand == "structure" and plan.peaks == [PeakSpec("tip", "uy")]
    cmd = plan.command(plan.cases[1])
    assert cmd[1:5] == ["-m", "mpsfem.cli", "structure", str(CANTILEVER)]
    assert cmd[-4:] == ["--set", "run.end_time=0.2", "--set", "structure.members.0.thickness=0.02"]
