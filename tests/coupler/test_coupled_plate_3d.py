"""A coupled 3D run: the MPS fluid on a Kirchhoff plate (scenarios/hydrostatic_plate_3d.toml).

Ten windows at the scenario's coarse spacing (l0 = 0.02 m, 1000 fluid particles): the plate is
laid in the 3D fluid (fluid_mps.plate_surface), its load at t0 is the water column's weight
rho g (H + l0/2) a^2 (the pressure layer sits half a spacing below the wetted face), every
window converges, and the results hold the plate's nodal displacements and its mid-point probe in
three components. The deflection against Kirchhoff's clamped square plate is the slow test in
test_coupled_validation.py.
"""

from __future__ import annotations

from pathlib import Path

import h5py
import numpy as np
import pytest

from mpsfem.scenario.loader import load_scenario
from mpsfem.simulation import run_coupled

ROOT = Path(__file__).resolve().parents[2]
SCENE = ROOT / "scenarios" / "hydrostatic_plate_3d.toml"
RHO, G, H, A, L0 = 1000.0, 9.81, 0.2, 0.2, 0.02
WINDOWS = 10


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    out = tmp_path_factory.mktemp("plate3d") / "plate.h5"
    sets = ["run.threads=1", "output.snapshot_interval=0", "output.probe_interval=0"]
    summary = run_coupled(
        load_scenario(SCENE, sets), out, WINDOWS * 2e-4, progress=False, log=lambda m: None
    )
    return summary, out


def test_initial_load_is_the_water_column(run):
    _, out = run
    with h5py.File(out, "r") as h5:
        f0 = h5["probes/plate_force/value"][0]
    exact = -RHO * G * (H + 0.5 * L0) * A * A
    print(f"3D plate: load at t0 {f0} N, rho g (H + l0/2) a^2 = {exact:.4f} N")
    assert f0[2] == pytest.approx(exact, rel=1e-12)
    assert np.abs(f0[:2]).max() < 1e-9 * abs(f0[2])


def test_windows_converge_and_results_are_3d(run):
    summary, out = run
    with h5py.File(out, "r") as h5:
        assert h5["coupling/converged"][:].all()
        assert h5["coupling/window"].shape == (WINDOWS,)
        disp = h5["structure/plate/displacement"][:]
        nodes = h5["structure/plate/nodes"][:]
        t, w = h5["probes/mid_deflection/time"][:], h5["probes/mid_deflection/value"][:]
    assert nodes.shape == (121, 3) and disp.shape[1:] == (121, 3)
    assert w.shape == (WINDOWS + 1, 3) and t[-1] == pytest.approx(WINDOWS * 2e-4)
    # the plate starts to sag under the water: only the normal component moves
    assert w[-1, 2] < 0.0 and np.abs(w[:, :2]).max() == 0.0


def test_polygonal_plate_is_refused_before_any_compute(tmp_path):
    member = (
        'structure.members.0={name = "plate", type = "plate", element = "morley", '
        'origin = [0.0, 0.0, -0.005], shape = "polygon", outline = [[0, 0], [0.2, 0], [0.1, 0.2]], '
        'mesh_size = 0.05, bc = "clamped", thickness = 0.01, '
        "material = {youngs_modulus = 1e9, poisson_ratio = 0.3, density = 1200.0}}"
    )
    out = tmp_path / "poly.h5"
    with pytest.raises(ValueError, match=r"'plate': shape = 'polygon'.*shape = \"rectangle\""):
        run_coupled(load_scenario(SCENE, [member]), out, 2e-4, progress=False, log=lambda m: None)
    assert not out.exists()
