"""Still water in 3D (scenarios/hydrostatic_3d.toml): the solver's dimension is a parameter.

Reference: hydrostatics, p = rho g (H - z). The 3D run at l0 = 0.01 m (1500 fluid particles,
0.5 s) measured the gauge 0.05 m above the floor at 977 Pa against 981 Pa (-0.4 %, time mean
over 0.1-0.5 s), the highest particle at 0.1494 m and a velocity rms of 0.03 m/s. CI runs a
shorter, shallower version; the tolerance is the 2D case's 2 %.
"""

import h5py
import numpy as np

from mpsfem.scenario.loader import load_scenario
from mpsfem.simulation import run_fluid

RHO, G = 1000.0, 9.81


def test_still_water_3d(tmp_path, scenarios_dir):
    H, zg, l0 = 0.1, 0.03, 0.01
    loaded = load_scenario(
        scenarios_dir / "hydrostatic_3d.toml",
        [
            "fluid.blocks.0.upper=[0.08, 0.08, 0.1]",
            "fluid.walls.0.upper=[0.08, 0.08, 0.16]",
            "probes.0.position=[0.04, 0.04, 0.03]",
            "output.snapshot_interval=0.1",
        ],
    )
    out = tmp_path / "still3d.h5"
    run_fluid(loaded, out, end_time=0.2, progress=False)
    with h5py.File(out, "r") as h5:
        t = h5["probes/gauge/time"][:]
        p = h5["probes/gauge/value"][:]
        snaps = h5["particles"]
        last = max(snaps, key=lambda k: float(snaps[k].attrs["time"]))
        kind = snaps[last]["kind"][:]
        pos = snaps[last]["pos"][:]
    fluid = kind == 0
    assert fluid.sum() == 8 * 8 * 10  # nothing lost or created
    assert pos[fluid, 2].max() < H + l0  # no particle leaves the water
    assert np.all(np.isfinite(p))
    mean = p[(t >= 0.05)].mean()
    exact = RHO * G * (H - zg)
    print(f"3D still water: gauge {mean:.1f} Pa against {exact:.1f} Pa")
    assert abs(mean - exact) <= 0.02 * exact
