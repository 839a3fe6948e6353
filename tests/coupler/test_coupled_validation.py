"""Validation of the coupled MPS-FEM runs (slow; ``pytest -m slow``). Numbers in
docs/validation.md, section "Coupled FSI".

* Hydrostatic water column on a clamped elastic plate (references.md section 5): the time mean of
  the mid-span deflection after the start-up transient within 5 % of the literature's
  6.85e-5 m, at l0 = 0.02 m and 0.01 m.
* Added-mass stress test on the same plate (self-weight off, static deflection 6.43e-5 m): at
  (rho_s h) / (rho_w H) = 0.01 explicit coupling diverges and the code says so
  (CouplingDivergedError from the added-mass detector); implicit IQN-ILS converges every window
  and settles at the static deflection; at 10 explicit coupling is stable.
* Hydrostatic water column on a clamped square plate in 3D (scenarios/hydrostatic_plate_3d.toml):
  the time mean of the centre deflection after 0.01 s within 5 % of Kirchhoff's
  0.001265 q a^4 / D = 4.597e-5 m, at l0 = 0.02 m and 0.01 m.
* Dam break on the elastic obstacle: the coupled run to 0.5 s and the plate-tip history (the
  figure docs/figures/dam_break_elastic_obstacle_tip.png is written when MPSFEM_WRITE_FIGURES=1).
"""

from __future__ import annotations

import os
from pathlib import Path

import h5py
import numpy as np
import pytest

from mpsfem.scenario.loader import load_scenario
from mpsfem.simulation import RunFailed, run_coupled

pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[2]
PLATE = ROOT / "scenarios" / "hydrostatic_plate_2d.toml"
OBSTACLE = ROOT / "scenarios" / "dam_break_elastic_obstacle_2d.toml"
PLATE_3D = ROOT / "scenarios" / "hydrostatic_plate_3d.toml"
W_KIRCHHOFF = (
    0.001265
    * (1000.0 * 9.81 * 0.2 + 1200.0 * 9.81 * 0.01)
    * 0.2**4
    / (1e9 * 0.01**3 / (12 * (1 - 0.3**2)))
)  # m, clamped square plate under water column + self-weight (Timoshenko, Table 35)
W_REF = 6.85e-5  # m, literature (references.md section 5)
W_WATER = 6.43e-5  # m, water load only
QUIET = dict(progress=False, log=lambda m: None)


def probe(path, name):
    with h5py.File(path, "r") as h5:
        return h5[f"probes/{name}/time"][:], h5[f"probes/{name}/value"][:]


@pytest.mark.parametrize(
    ("scene", "spacing", "end", "settled", "reference"),
    [
        (PLATE, 0.02, 0.25, 0.05, W_REF),
        (PLATE, 0.01, 0.15, 0.05, W_REF),
        (PLATE_3D, 0.02, 0.06, 0.01, W_KIRCHHOFF),
        (PLATE_3D, 0.01, 0.05, 0.01, W_KIRCHHOFF),
    ],
    ids=["2d-0.02", "2d-0.01", "3d-0.02", "3d-0.01"],
)
def test_hydrostatic_plate_mean_deflection(tmp_path, scene, spacing, end, settled, reference):
    """Time mean of the mid-point deflection after the start-up transient (``settled`` s)
    within 5 % of the reference (vertical = the scene's last axis)."""
    sets = [f"fluid.spacing={spacing}", "output.snapshot_interval=0"]
    out = tmp_path / "plate.h5"
    run_coupled(load_scenario(scene, sets), out, end, **QUIET)
    t, v = probe(out, "mid_deflection")
    mean = -v[t >= settled, -1].mean()
    print(
        f"{scene.stem}, l0 = {spacing}: mean deflection {mean:.4e} m ({mean / reference - 1:+.2%})"
    )
    assert mean == pytest.approx(reference, rel=0.05)


def stress(tmp_path, ratio, scheme, accel=None, end=0.03):
    rho_s = ratio * 1000.0 * 2.0 / 0.05
    sets = [
        "fluid.spacing=0.05",
        f"structure.members.0.material.density={rho_s!r}",
        "structure.members.0.self_weight=false",
        "output.snapshot_interval=0",
        "output.probe_interval=0",
        f'coupling.scheme="{scheme}"',
    ]
    if accel:
        sets.append(f'coupling.acceleration={{kind = "{accel}"}}')
    out = tmp_path / f"{scheme}_{ratio}.h5"
    run_coupled(load_scenario(PLATE, sets), out, end, **QUIET)
    return out


def test_explicit_coupling_diverges_at_low_mass_ratio_and_iqn_ils_does_not(tmp_path):
    with pytest.raises(RunFailed) as err:
        stress(tmp_path, 0.01, "explicit")
    assert "added-mass instability" in str(err.value)
    out = stress(tmp_path, 0.01, "implicit", "iqn-ils")
    with h5py.File(out, "r") as h5:
        assert (h5["coupling/converged"][:] == 1).all()
        it = h5["coupling/iterations"][:]
    t, v = probe(out, "mid_deflection")
    mean = -v[t >= 0.015, 1].mean()
    print(f"ratio 0.01, IQN-ILS: {it.mean():.2f} iterations/window, mean deflection {mean:.3e} m")
    assert mean == pytest.approx(W_WATER, rel=0.15)


def test_explicit_coupling_is_stable_at_high_mass_ratio(tmp_path):
    out = stress(tmp_path, 10.0, "explicit")
    with h5py.File(out, "r") as h5:
        assert h5.attrs["status"] == "finished"


def test_dam_break_on_elastic_obstacle(tmp_path):
    out = tmp_path / "obstacle.h5"
    end = 0.5
    run_coupled(load_scenario(OBSTACLE, ["output.snapshot_interval=0.05"]), out, end, **QUIET)
    t, tip = probe(out, "tip")
    k = int(np.argmax(tip[:, 0]))
    print(f"tip: peak u_x {tip[k, 0]:.4e} m at t = {t[k]:.3f} s")
    assert t[-1] == pytest.approx(end)
    assert tip[k, 0] > 0.0  # the surge pushes the tip downstream
    if os.environ.get("MPSFEM_WRITE_FIGURES"):
        plot_tip(t, tip, ROOT / "docs" / "figures" / "dam_break_elastic_obstacle_tip.png")


def plot_tip(t, tip, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    path.parent.mkdir(parents=True, exist_ok=True)
    fig, ax = plt.subplots(figsize=(6, 3.2))
    ax.plot(t, 1e3 * tip[:, 0], label="tip $u_x$")
    ax.plot(t, 1e3 * tip[:, 1], label="tip $u_y$")
    ax.set_xlabel("t (s)")
    ax.set_ylabel("displacement (mm)")
    ax.set_title("Dam break on an elastic obstacle: plate tip")
    ax.grid(alpha=0.3)
    ax.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
