"""Structure-only runs write the results-file contract; the scenario files load and run."""

import math
from pathlib import Path

import h5py
import numpy as np
import pytest
from structure_cases import load

from mpsfem.structure_fem.loads import read_table_csv
from mpsfem.structure_fem.standalone import _last_step, modal_analysis, run_structure

SCENARIOS = Path(__file__).resolve().parents[2] / "scenarios"
CANTILEVER = SCENARIOS / "structure_cantilever_demo.toml"


def test_cantilever_run_writes_readable_results(tmp_path):
    loaded = load(CANTILEVER, ["run.end_time=0.5"])
    out = tmp_path / "cantilever.h5"
    summary = run_structure(loaded, out, progress=False)
    assert summary.steps == 1000 and summary.t == pytest.approx(0.5)
    assert summary.factorizations == 1
    with h5py.File(out, "r") as h5:
        assert h5.attrs["status"] == "finished"
        assert "cantilever" in h5.attrs["scenario"]
        g = h5["structure/cantilever"]
        nodes, t, d = g["nodes"][:], g["time"][:], g["displacement"][:]
        assert nodes.shape == (41, 2) and np.allclose(nodes[-1], [1.0, 0.0])
        assert d.shape == (len(t), 41, 2)
        assert t[0] == 0.0 and t[-1] == pytest.approx(0.5)
        assert np.allclose(np.diff(t), 0.01)  # record_interval
        tip = h5["probes/tip"]
        assert tip.attrs["kind"] == "displacement" and tip.attrs["unit"] == "m"
        assert list(tip.attrs["components"]) == ["ux", "uy"]
        assert np.allclose(tip.attrs["position"], [1.0, 0.0])
        pt, pv = tip["time"][:], tip["value"][:]
        assert pv.shape == (len(pt), 2) and len(pt) == 1001  # every step (probe_interval = dt)
        assert np.allclose(pv[:, 0], 0.0)
        # probe at the tip = last node of the structure record
        k = np.searchsorted(pt, t[-1])
        assert np.allclose(pv[k], d[-1, -1])
        e = h5["probes/energy"]
        assert list(e.attrs["components"]) == ["kinetic", "strain"]
        assert e.attrs["unit"] == "J/m"  # 2D: per metre of width
    # damped oscillation about the static deflection P L^3 / (3 E I), peak near 2 x static
    static = -100.0 / (3 * 2.1e11 * 0.01**3 / 12)
    assert 1.85 < pv[:, 1].min() / static < 2.0
    two_periods = int(round(2 / 8.382 / 5e-4))
    assert abs(pv[-two_periods:, 1].mean() / static - 1) < 0.05


def test_table_load_from_csv_file(tmp_path):
    """A `table` time function read from a CSV next to the scenario (relative path) gives the
    same run as the equivalent `ramp` (to round-off: np.interp vs (t - t0) / T)."""
    outs = []
    for k, tf in enumerate(
        ['{ kind = "table", file = "ramp.csv" }', '{ kind = "ramp", start = 0.0, duration = 0.2 }']
    ):
        text = CANTILEVER.read_text().replace(
            'time = { kind = "step", start = 0.0 }', f"time = {tf}"
        )
        scen = tmp_path / f"cantilever_{k}.toml"
        scen.write_text(text)
        (tmp_path / "ramp.csv").write_text("# ramp\nt,f\n0.0,0.0\n0.2,1.0\n")
        out = tmp_path / f"r{k}.h5"
        run_structure(load(scen, ["run.end_time=0.3"]), out, progress=False)
        with h5py.File(out, "r") as h5:
            outs.append(h5["probes/tip/value"][:])
    assert np.allclose(outs[0], outs[1], rtol=1e-12, atol=1e-18)
    assert np.abs(outs[0]).max() > 0


@pytest.mark.parametrize(
    "name, f1",
    [
        ("structure_green_water_plate.toml", 80.87),
        ("structure_bottom_slamming_2d.toml", 2.267),
        ("structure_bottom_slamming_3d.toml", 8.768),
        ("structure_cantilever_demo.toml", 8.382),
    ],
)
def test_scenario_files_first_frequency(name, f1):
    loaded = load(SCENARIOS / name)
    res = next(iter(modal_analysis(loaded, 2).values()))
    print(f"{name}: f1 = {res.frequency[0]:.5g} Hz, zeta1 = {res.damping_ratio[0]:.4g}")
    assert res.frequency[0] == pytest.approx(f1, rel=1e-3)


def test_thesis_members_closed_form():
    """First frequencies of the thesis members against closed forms (references.md s. 3)."""
    # green-water plate: clamped - simply supported beam, beta_1 L = 3.926602
    gw = next(
        iter(modal_analysis(load(SCENARIOS / "structure_green_water_plate.toml"), 1).values())
    )
    EI, rhoA, L = 35e6 * 0.04**3 / 12, 1100 * 0.04, 0.25
    ref = 3.926602**2 * np.sqrt(EI / (rhoA * L**4))
    assert gw.omega[0] == pytest.approx(ref, rel=1e-5)
    assert gw.damping_ratio[0] == pytest.approx(0.05, rel=2e-3)
    # bottom plate: simply supported, (pi / L)^2 sqrt(EI / rho A)
    bp = next(
        iter(modal_analysis(load(SCENARIOS / "structure_bottom_slamming_2d.toml"), 2).values())
    )
    EI, rhoA, L = 1e6 * 0.015**3 / 12, 1040 * 0.015, 0.305
    ref = (np.pi / L) ** 2 * np.sqrt(EI / rhoA)
    assert bp.omega[0] == pytest.approx(ref, rel=1e-6)
    # the thesis's a1, a2 with its own tables' section read as I = 1e-9 m^4: 5 % in modes 1, 2
    alt = load(
        SCENARIOS / "structure_bottom_slamming_2d.toml",
        ["structure.members.0.area=2.5e-5", "structure.members.0.second_moment=1e-9"],
    )
    z = next(iter(modal_analysis(alt, 2).values())).damping_ratio
    assert np.allclose(z, 0.05, rtol=2e-3)


@pytest.mark.slow
@pytest.mark.parametrize(
    "name",
    [
        "structure_green_water_plate.toml",
        "structure_bottom_slamming_2d.toml",
        "structure_bottom_slamming_3d.toml",
        "structure_cantilever_demo.toml",
    ],
)
def test_scenario_files_run(name, tmp_path):
    out = tmp_path / "out.h5"
    summary = run_structure(load(SCENARIOS / name), out, progress=False)
    with h5py.File(out, "r") as h5:
        assert h5.attrs["status"] == "finished"
        for g in h5["structure"].values():
            assert np.isfinite(g["displacement"][:]).all()
    print(f"{name}: {summary.steps} steps in {summary.wall_time:.2f} s")


def test_cli_main_structure_and_modes(tmp_path, monkeypatch, capsys):
    """cli_main implements `mpsfem structure` and `mpsfem modes` (argparse namespace)."""
    from types import SimpleNamespace

    import mpsfem.scenario.loader as loader
    from mpsfem.structure_fem.standalone import cli_main

    monkeypatch.setattr(loader, "load_scenario", lambda path, overrides=(): load(path, overrides))
    rc = cli_main(SimpleNamespace(command="modes", scenario=CANTILEVER, overrides=[], count=3))
    out = capsys.readouterr().out
    assert rc == 0 and "cantilever" in out and "8.3819" in out and len(out.splitlines()) == 4
    h5 = tmp_path / "c.h5"
    rc = cli_main(
        SimpleNamespace(
            command="structure", scenario=CANTILEVER, overrides=["run.end_time=0.01"], out=h5,
            no_progress=True,
        )
    )  # fmt: skip
    assert rc == 0 and h5.is_file()
    assert "finished t = 0.01 s in 20 steps" in capsys.readouterr().out


@pytest.mark.parametrize("T, dt", [(1.5, 5e-5), (3.0, 1e-4), (0.3, 1e-4), (0.25, 1e-3)])
def test_last_step_is_dt_up_to_round_off(T, dt):
    """30000 steps of 5e-5 s leave T - (n - 1) dt a few 1e-12 dt away from dt, beyond the
    integrator's 1e-12 cache snap: the last step is dt itself, so it reuses the factorisation."""
    n = math.ceil(T / dt - 1e-9)
    assert _last_step(T, dt, n) == dt
    assert _last_step(0.2505, 1e-3, 251) == pytest.approx(5e-4, rel=1e-9)  # a true short step


@pytest.mark.parametrize(
    "text, match",
    [
        ("t,f\n0.0,0.0\n0.1,1,5\n", r"line 3: 3 values .*two numbers"),
        ("0.0,0.0\n0.1\n", r"line 2: 1 values .*two numbers"),
        ("0.0,0.0\n0.1,x\n", r"line 2: not numbers"),
        ("0.0,0.0\n0.0,1.0\n", r"strictly increasing"),
    ],
)
def test_bad_load_table_names_file_and_line(tmp_path, text, match):
    path = tmp_path / "load.csv"
    path.write_text(text)
    with pytest.raises(ValueError, match=match) as err:
        read_table_csv(path)
    assert str(path) in str(err.value)
    path.write_text("# t, f\nt,f\n0.0,0.0\n0.1,1.0\n")
    assert read_table_csv(path).tolist() == [[0.0, 0.0], [0.1, 1.0]]
