"""Rubber gate dam break (Antoci et al. 2007; issue 21): scenarios/elastic_gate_2d.toml.

CI: the scenario validates with the co-rotational gate and the large-rotation mapping, at every
spacing of validation/elastic_gate.py; and a coarse, short coupled run (l0 = 5 mm, windows of
0.5 ms, 0.03 s simulated; see COARSE) swings the gate open: its tip rises by the foreshortening of a bent
cantilever, dy = 0.6 dx^2 / L (the static tip-load shape w = dx (3 s^2 L - s^3) / (2 L^3) has
(1/2) int (w')^2 ds = 0.6 dx^2 / L), which a geometrically linear beam cannot give (its tip dy
is its axial stretch under its own weight, rho g L^2 / (2 E) = 2.8e-6 m, downward).

Slow (-m slow): the study's CSV (validation/results/elastic_gate_cases.csv) holds every spacing
with every window converged but a few, and peaks of the same size.
"""

from __future__ import annotations

from pathlib import Path

import h5py
import numpy as np
import pytest
from validation_script import load

from mpsfem.scenario.loader import load_scenario
from mpsfem.simulation import run_coupled

ROOT = Path(__file__).resolve().parents[2]
SCENARIO = ROOT / "scenarios" / "elastic_gate_2d.toml"
gate = load("elastic_gate")

L_GATE = 0.079
#: coarse CI case: 16 columns along the gate, 560 fluid particles; the window and the fluid's
#: largest step 5e-4 s (Courant 0.1 at 1 m/s); 0.03 s simulated (dx about 5 mm). The wall above
#: the clamp is widened downstream to 2 spacings (a solid box needs them); the 6 mm gap is 1.2
#: spacings here, so little water passes under the gate
COARSE = [
    "fluid.spacing=0.005",
    "fluid.walls.1.upper=[0.11, 0.3]",
    "fluid.time_step.dt_max=5e-4",
    "structure.time.dt=5e-4",
    "output.snapshot_interval=0",
    "output.checkpoint_interval=0",
]
END_TIME = 0.03


@pytest.mark.parametrize("l0", gate.SPACINGS)
def test_scenario_validates_with_the_corotational_gate(l0):
    sc = load_scenario(SCENARIO, gate.overrides(l0, gate.END_TIME)).scenario
    (member,) = sc.structure.members
    assert member.kinematics == "corotational" and member.bc == ["clamped", "free"]
    assert np.hypot(*(np.subtract(member.end, member.start))) == pytest.approx(L_GATE)
    assert sc.coupling.mapping.large_rotation and sc.coupling.scheme == "implicit"
    gap = min(member.start[1], member.end[1])
    assert gap >= 2 * l0 - 1e-12  # room for the fluid to pass under the gate
    assert member.material.youngs_modulus == 12e6 and member.material.density == 1100.0


def test_short_coarse_run_swings_the_corotational_gate_open(tmp_path):
    out = tmp_path / "gate.h5"
    loaded = load_scenario(SCENARIO, COARSE)
    run_coupled(loaded, out, progress=False, end_time=END_TIME, log=lambda m: None)
    with h5py.File(out, "r") as h5:
        tip = h5["probes/tip/value"][:]
        t = h5["probes/tip/time"][:]
    assert t[-1] == pytest.approx(END_TIME)
    assert np.isfinite(tip).all()
    dx, dy = tip[-1]
    assert dx > 2e-3  # the water pushes the gate open (+x, downstream)
    # the tip rises by the bent cantilever's foreshortening; 25 %: the dynamic shape is not the
    # static one (measured: 2.5 % at 0.04 s here; the 3 mm production run: 0.92 mm against
    # 0.94 mm at dx = 11.1 mm)
    assert dy == pytest.approx(0.6 * dx**2 / L_GATE, rel=0.25)


@pytest.mark.slow
def test_production_results_agree_across_spacings():
    """validation/results/elastic_gate_cases.csv: every study spacing ran to 0.4 s with at most
    0.5 % of the windows unconverged; the dx and dy peaks of consecutive spacings agree within
    10 % (measured: at most 3 % and 8 %), at the same time within 10 ms, and each dy peak is the bent
    cantilever's foreshortening 0.6 dx^2 / L within 10 % (the shape at the peak is dynamic)."""
    results_csv = load("results_csv")
    rows = {
        float(r["spacing_m"]): r
        for r in results_csv.read_csv(gate.RESULTS_DIR / "elastic_gate_cases.csv")
    }
    assert set(gate.SPACINGS) <= set(rows)
    peaks = []
    for l0 in gate.SPACINGS:
        r = rows[l0]
        assert r["status"] == "finished" and float(r["t_end_s"]) == pytest.approx(gate.END_TIME)
        assert int(r["unconverged_windows"]) <= 0.005 * int(r["windows"])
        dx, dy = float(r["dx_max_m"]), float(r["dy_max_m"])
        assert dy == pytest.approx(0.6 * dx**2 / L_GATE, rel=0.1)
        peaks.append((dx, dy, float(r["t_dx_max_s"])))
    for (dx0, dy0, t0), (dx1, dy1, t1) in zip(peaks[:-1], peaks[1:], strict=True):
        assert dx1 == pytest.approx(dx0, rel=0.1) and dy1 == pytest.approx(dy0, rel=0.1)
        assert abs(t1 - t0) < 0.01
