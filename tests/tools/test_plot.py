"""`mpsfem plot`: one valid PNG per series, reference CSV overlay, clear errors."""

import subprocess
import sys
from pathlib import Path

import matplotlib.image
import numpy as np
import pytest

from mpsfem.cli import main
from mpsfem.results.results_file import ResultsFile
from mpsfem.tools import ToolError
from mpsfem.tools.plot import match_reference, parse_reference_arg, plot_results
from mpsfem.tools.reference_csv import read_reference_csv
from mpsfem.tools.results_series import list_targets, open_results, read_series

ROOT = Path(__file__).resolve().parents[2]
CANTILEVER = ROOT / "scenarios" / "structure_cantilever_demo.toml"
PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"

T = np.linspace(0.0, 1.0, 51)


@pytest.fixture
def results(tmp_path) -> Path:
    """A small results file written by the project's writer: a scalar probe with a dry spell
    (NaN), a two-component force probe, a structure member and coupling windows."""
    path = tmp_path / "case.h5"
    rf = ResultsFile.create(path, "title = 'synthetic'")
    rf.add_probe("gauge", "pressure", "Pa", (), position=[0.5, 0.1])
    rf.add_probe("load", "force", "N", ("fx", "fy"))
    rf.add_structure("plate", np.array([[0.0, 0.0], [0.5, 0.0], [1.0, 0.0]]))
    for t in T:
        rf.append_probe("gauge", t, np.nan if 0.2 < t < 0.3 else 1000.0 * t)
        rf.append_probe("load", t, [np.sin(2 * np.pi * t), np.cos(2 * np.pi * t)])
        shape = np.array([[0.0, 0.0], [0.0, 0.5], [0.0, 1.0]])  # tip node moves most
        rf.append_structure("plate", t, 1e-3 * np.sin(np.pi * t) * shape)
    for k in range(1, 5):
        rf.append_coupling(0.25 * k, 2 + k, 10.0**-k, work_fluid=0.1 * k)
    rf.close("finished")
    return path


def _valid_png(path: Path) -> np.ndarray:
    assert path.read_bytes()[:8] == PNG_SIGNATURE
    img = matplotlib.image.imread(path)
    assert img.ndim == 3 and img.shape[0] > 200 and img.shape[1] > 300
    assert img.std() > 0.01  # something is drawn
    return img


def test_series_read_back(results):
    with open_results(results) as h5:
        assert list_targets(h5) == ["gauge", "load", "structure/plate", "coupling"]
        load = read_series(h5, "load")
        assert load.components == ["fx", "fy"] and load.units == ["N", "N"]
        np.testing.assert_array_equal(load.component("fy"), np.cos(2 * np.pi * T))
        plate = read_series(h5, "structure/plate")
        assert plate.attrs["node"] == 2 and plate.components == ["ux", "uy", "|u|max"]
        np.testing.assert_allclose(plate.component("uy"), 1e-3 * np.sin(np.pi * T))
        np.testing.assert_allclose(plate.component("|u|max"), 1e-3 * np.sin(np.pi * T))
        coupling = read_series(h5, "coupling")
        assert coupling.components == ["iterations", "residual", "work_fluid"]
        np.testing.assert_array_equal(coupling.component("iterations"), [3, 4, 5, 6])


def test_one_png_per_series(results, tmp_path, capsys):
    out = tmp_path / "plots"
    assert main(["plot", str(results), "--out", str(out)]) == 0
    names = sorted(p.name for p in out.iterdir())
    assert names == ["coupling.png", "probe-gauge.png", "probe-load.png", "structure-plate.png"]
    for p in out.iterdir():
        _valid_png(p)
    assert capsys.readouterr().out.count("wrote ") == 4


def test_default_folder_and_selection(results):
    paths = plot_results(results, ["load", "coupling/residual"])
    assert [p.name for p in paths] == ["probe-load.png", "coupling-residual.png"]
    assert all(p.parent == results.with_name("case_plots") for p in paths)


def test_reference_overlay_changes_the_plot(results, tmp_path):
    ref = tmp_path / "ref.csv"
    t = np.linspace(0.0, 1.0, 11)
    rows = "\n".join(f"{a:.3f}, {b:.6f}" for a, b in zip(t, -np.cos(2 * np.pi * t), strict=True))
    ref.write_text("# published curve\ntime, fy\n" + rows + "\n")
    bare = _valid_png(plot_results(results, ["load"], out_dir=tmp_path / "a")[0])
    spec = parse_reference_arg(str(ref))
    with_ref = _valid_png(plot_results(results, ["load"], [spec], tmp_path / "b")[0])
    assert bare.shape == with_ref.shape and np.abs(bare - with_ref).max() > 0.1
    # the header names the component: overlaid on fy only
    curve = read_reference_csv(ref)
    with open_results(results) as h5:
        load = read_series(h5, "load")
    assert curve.names == ["fy"] and curve.values.shape == (11, 1)
    assert match_reference(load, curve, None) == [(1, 0)]


def test_reference_matching_rules(results, tmp_path):
    with open_results(results) as h5:
        load = read_series(h5, "load")
        gauge = read_series(h5, "gauge")
    two = tmp_path / "two.csv"
    two.write_text("0 1 2\n1 2 3\n")  # no comma: whitespace-separated, no header
    curve = read_reference_csv(two)
    assert curve.names is None and curve.values.shape == (2, 2)
    assert match_reference(load, curve, None) == [(0, 0), (1, 1)]  # in order
    one = tmp_path / "one.csv"
    one.write_text("time,value\n0,1\n")
    assert match_reference(load, read_reference_csv(one), "fy") == [(1, 0)]
    with pytest.raises(ToolError, match="2 value columns but gauge has 1 component"):
        match_reference(gauge, curve, None)
    with pytest.raises(ToolError, match="no component 'fz'; its components are fx, fy"):
        match_reference(load, read_reference_csv(one), "fz")
    partly = tmp_path / "partly.csv"
    partly.write_text("t,fx,lift\n0,1,2\n")
    with pytest.raises(ToolError, match=r"header columns \['lift'\] are not components"):
        match_reference(load, read_reference_csv(partly), None)


def test_reference_for_named_series_via_cli(results, tmp_path, capsys):
    ref = tmp_path / "gauge.csv"
    ref.write_text("0.0,0\n0.5,480\n1.0,1010\n")
    out = tmp_path / "p"
    rc = main(
        ["plot", str(results), "--reference", f"gauge={ref}", "--probe", "load", "--out", str(out)]
    )
    assert rc == 0
    assert sorted(p.name for p in out.iterdir()) == ["probe-gauge.png", "probe-load.png"]


def test_errors_are_clear(results, tmp_path, capsys):
    assert main(["plot", str(tmp_path / "missing.h5")]) == 2
    err = capsys.readouterr().err
    assert "results file" in err and "missing.h5' does not exist" in err
    assert main(["plot", str(results), "--probe", "gage"]) == 2
    err = capsys.readouterr().err
    assert "no series named 'gage'" in err
    assert "available: gauge, load, structure/plate, coupling, coupling/iterations" in err
    bad = tmp_path / "bad.csv"
    bad.write_text("time,value\n0.0,1.0\n# note\n0.1,2.0,3.0\n")
    assert main(["plot", str(results), "--probe", "gauge", "--reference", str(bad)]) == 2
    err = capsys.readouterr().err
    assert f"{bad} line 4" in err and "has 3 fields; expected 2" in err
    bad.write_text("0.0,1.0\n0.1,abc\n")
    assert main(["plot", str(results), "--probe", "gauge", "--reference", str(bad)]) == 2
    assert (
        f"{bad} line 2: field 2 (value column 1) 'abc' is not a number" in capsys.readouterr().err
    )
    bad.write_text("# only a comment\ntime,value\n")
    with pytest.raises(ToolError, match="only a header line"):
        read_reference_csv(bad)
    bad.write_text("0.0\n0.1\n")
    with pytest.raises(ToolError, match="line 1: '0.0' has 1 field; expected at least 2"):
        read_reference_csv(bad)
    ok = tmp_path / "ok.csv"
    ok.write_text("0,1\n")
    assert main(["plot", str(results), "--reference", str(ok)]) == 2  # which series?
    assert "say which one it belongs to with --reference NAME" in capsys.readouterr().err
    not_h5 = tmp_path / "x.h5"
    not_h5.write_text("not hdf5")
    assert main(["plot", str(not_h5)]) == 2
    assert "is not an HDF5 results file" in capsys.readouterr().err
    assert not (tmp_path / "x_plots").exists()  # nothing written on an error


def test_file_held_by_a_writer(results):
    """A results file another process holds open for writing (a run in progress) opens all the
    same, read as its writer's last flush left it (issue 22: readers failed with a lock error;
    docs/results.md, "Reading a running file")."""
    code = "import h5py, sys; f = h5py.File(sys.argv[1], 'a'); print('open', flush=True); input()"
    writer = subprocess.Popen(
        [sys.executable, "-c", code, str(results)],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
    )
    try:
        assert writer.stdout.readline().strip() == "open"
        with open_results(results) as h5:
            assert "probes" in h5
    finally:
        writer.communicate("\n", timeout=30)


def test_plot_of_a_real_structure_run(tmp_path, monkeypatch, capsys):
    """The plot of an actual `mpsfem structure` run: the tip probe and the member."""
    monkeypatch.chdir(tmp_path)
    out = tmp_path / "cantilever.h5"
    args = ["structure", str(CANTILEVER), "--out", str(out), "--no-progress"]
    assert main([*args, "--set", "run.end_time=0.05"]) == 0
    assert main(["plot", str(out), "--probe", "tip", "structure/cantilever"]) == 0
    for name in ("probe-tip.png", "structure-cantilever.png"):
        _valid_png(tmp_path / "cantilever_plots" / name)
    with open_results(out) as h5:
        member = read_series(h5, "structure/cantilever")
    assert member.attrs["node"] == 40  # the free end moves most
