"""Probe units follow the contract: in 2D forces are N/m and energies J/m (per unit width)."""

from pathlib import Path
from types import SimpleNamespace

import h5py
import pytest

from mpsfem.fluid_mps.probes import probe_unit
from mpsfem.scenario.loader import load_scenario
from mpsfem.simulation import _probe_meta, run_coupled, run_fluid

SCENARIOS = Path(__file__).resolve().parents[2] / "scenarios"


@pytest.mark.parametrize(
    ("kind", "unit_2d", "unit_3d"),
    [
        ("pressure", "Pa", "Pa"),
        ("wave_gauge", "m", "m"),
        ("front", "m", "m"),
        ("force", "N/m", "N"),
        ("energy", "J/m", "J"),
        ("displacement", "m", "m"),
    ],
)
def test_unit_per_kind_and_dimension(kind, unit_2d, unit_3d):
    assert probe_unit(kind, 2) == unit_2d and probe_unit(kind, 3) == unit_3d
    probe = SimpleNamespace(kind=kind)
    assert _probe_meta(probe, 2)[0] == unit_2d and _probe_meta(probe, 3)[0] == unit_3d


def _units(path: Path) -> dict[str, str]:
    with h5py.File(path, "r") as h5:
        return {name: str(g.attrs["unit"]) for name, g in h5["probes"].items()}


def test_fluid_run_2d_writes_per_width_units(tmp_path):
    sets = ["fluid.spacing=0.0146", "run.threads=1", "output.checkpoint_interval=0"]
    out = tmp_path / "db.h5"
    run_fluid(load_scenario(SCENARIOS / "dam_break_2d.toml", sets), out, 0.002, progress=False)
    units = _units(out)
    assert units["tank_force"] == "N/m" and units["energy"] == "J/m"
    assert units["right_wall_p"] == "Pa" and units["front"] == "m"


def test_coupled_run_2d_writes_per_width_units(tmp_path):
    sets = ["fluid.spacing=0.05", "run.threads=1", "output.checkpoint_interval=0"]
    loaded = load_scenario(SCENARIOS / "hydrostatic_plate_2d.toml", sets)
    out = tmp_path / "plate.h5"
    run_coupled(loaded, out, 2e-4, progress=False, log=lambda m: None)
    units = _units(out)
    assert units["plate_energy"] == "J/m" and units["mid_deflection"] == "m"
    forces = [name for name, u in units.items() if u.startswith("N")]
    assert forces and all(units[name] == "N/m" for name in forces)
