"""Dam break on the elastic obstacle, coupled, with the δ-SPH fluid beside MPS (issue 23).

scenarios/dam_break_elastic_obstacle_2d.toml (Walhorn et al. 2005; Idelsohn et al. 2008: the
Koshizuka-Oka column L = 0.146 m against a clamped elastic plate 0.012 m x 0.08 m, E = 1 MPa,
rho_s = 2500 kg/m^3, co-rotational beam of 10 elements, implicit IQN-ILS, window 0.25 ms,
relative tolerance 1e-3, at most 30 iterations, a window that does not converge accepted with a
warning). The δ-SPH scenario is that file with fluid.method = "delta-sph" and MPS's numerical
tables ([fluid.pressure], fluid.time_step.courant) dropped, the default [fluid.sph] (δ-SPHC,
h = 1.3 l0, RK4, c0 = 20 sqrt(g 2L)) and fluid.momentum_budget = true (opt-in under δ-SPH); it
is written to validation/results/delta_sph_obstacle.toml. MPS runs the scenario itself (copied
to validation/results/delta_sph_obstacle_mps.toml), so both rows are of the current code. Both
copies get an instantaneous twin of the force probe (``force_last_step``, average = false).

Cases (``mpsfem run`` subprocesses, resumable; NUMBA_NUM_THREADS = --threads): δ-SPH and MPS
at l0 = L/20, L/40 and L/80 (issue 21) to 0.3 s (the co-rotational MPS study's end, past the
first tip peak), δ-SPH at L/20 and L/40 also with fluid.sph.structure_load = "normal_pairs"
(``*_pairs``: the fluid's pairs with the member projected too), and at L/20 to 0.6 s (the scenario's end: the mean tip u_x of 0.1 s blocks from 0.3 s). Per case: the tip's peak u_x and its time (and u_y there), the
first contact (first 1 ms force sample with |F_x| > 1 N/m), the peak of the interval-mean force
|F_x| over the impact 0.12-0.25 s and its ringing (RMS of the sample-to-sample jump of the 1 ms
samples over that peak: validation/momentum_budget.py's metric, issue 20; split into that of
an 11 ms cubic Savitzky-Golay fit, the load's own course, and that of the residual about it,
the noise), the same for the last-step force, the axial stretch of the plate (largest chord strain of the bottom element
between recorded nodes, with its time; the sum of the chords at the tip peak), coupling
iterations per window (mean, max), windows not converged, fluid steps,
the wall time, and from /momentum_budget over the impact window the member's impulse and
residual_external (dP - G + sum_b J_b, relative to sum_b |J_b|, per component). Writes
validation/results/delta_sph_obstacle.csv and prints the table.

    python validation/delta_sph_obstacle.py [--threads 1] [--analyse-only] [--retry-failed]
        [--cases dsph20 dsph40 mps20 mps40 dsph80 mps80 dsph20_long mps20_long dsph20_pairs
        dsph40_pairs dsph20_wetted dsph40_wetted]

``--cases`` picks the cases to run; the CSV lists every case, reading the others' results files.
Cases ``*_stiff`` give the plate E = 2e11 Pa (a member that does not move: the fluid's own load
noise, issue 20), ``mps20_stiff_*`` with switches of the pressure equation, the surface, the
step, the CG tolerance, the collision model (off, its distance), the viscosity, the pressure
equation's Laplacian radius and the wall model (``*_layer``: the thesis's
pressure layer, also on the elastic plate and at L/40). Cases ``dsph*_h2`` widen the δ-SPH kernel to h = 2 l0. Cases ``mps*_suction`` let the water pull on the plate (``fluid.pressure.structure_suction``,
docs/fluid.md). ``--noise-map`` re-runs --cases in process and writes the ringing node by node
(delta_sph_obstacle_noise.csv; ``noise_map``).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import h5py
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import case_runner  # noqa: E402 - resumable runs of one case
import momentum_budget  # noqa: E402 - the MPS study's ringing and budget metrics
from results_csv import read_csv, write_csv  # noqa: E402

ROOT = case_runner.ROOT
RESULTS = ROOT / "validation" / "results"
SOURCE = ROOT / "scenarios" / "dam_break_elastic_obstacle_2d.toml"
SPH_SCENARIO = RESULTS / "delta_sph_obstacle.toml"
MPS_SCENARIO = RESULTS / "delta_sph_obstacle_mps.toml"
CSV = RESULTS / "delta_sph_obstacle.csv"
CENTROID_CSV = RESULTS / "delta_sph_obstacle_centroid.csv"
CENTROID_SERIES_CSV = RESULTS / "delta_sph_obstacle_centroid_series.csv"
CENTROID_SPANS = ((0.12, 0.25), (0.12, 0.17), (0.17, 0.25))  # s
AXIAL_CSV = RESULTS / "delta_sph_obstacle_axial.csv"
NOISE_CSV = RESULTS / "delta_sph_obstacle_noise.csv"
NOISE_SPAN = (0.12, 0.25)  # s, the impact window of the ringing
AXIAL_SPAN = (0.12, 0.17)  # s, the first impact, where the whole exchange pushed the plate up
AXIAL_EVERY = 4  # windows between two samples of the pair split
L = 0.146  # m, the column width
IMPACT = (0.12, 0.25)  # s, the impact window of validation/momentum_budget.py
CONTACT_FORCE = 1.0  # N/m, |F_x| of the first sample counted as contact
#: fluid.sph.structure_load = "normal_pairs": the fluid's pairs with the member projected too
PAIRS = ('fluid.sph.structure_load="normal_pairs"',)
#: fluid.sph.wall_pressure = "wetted": no pressure on walls across an air gap (task H2)
WETTED = ('fluid.sph.wall_pressure="wetted"',)
#: the plate's wetted (left) face at x = 0.292 m, as the published reproductions place it
#: (docs/validation_elastic_obstacle_published.md): the beam axis 6 mm further from the column
FACE = (
    "structure.members.0.start=[0.298, 0.0]",
    "structure.members.0.end=[0.298, 0.08]",
    "probes.0.position=[0.298, 0.08]",
)
#: MPS: the walls' acceleration in their ghosts and the buried wall particles as ghosts (issue
#: 20, item 4: the piston's added mass in phase; docs/fluid.md, "Buried walls")
WALLS = ("fluid.pressure.wall_acceleration=true", 'fluid.pressure.buried_walls="ghost"')
#: MPS weakly compressible with shifting, c = 10 sqrt(g H) (validation/weakly_compressible_mps.py)
WEAKLY = ("fluid.pressure.shifting=0.1", "fluid.pressure.compressibility=3.5e-6")
#: a plate 2e5 times stiffer (E = 2e11 Pa: tip deflection ~0.2 um): the fluid's own noise on a
#: member that does not move, to tell it from the plate's vibration (issue 20, the ringing)
STIFF = ("structure.members.0.material.youngs_modulus=2e11",)
#: negative pressure kept next to the member away from the free surface (issue 21: can the
#: water pull on the plate?)
SUCTION = ("fluid.pressure.structure_suction=true",)
#: a wider δ-SPH kernel, h = 2 l0 (default 1.3 l0): more neighbours, a smoother pressure (issue
#: 20, the ringing)
WIDE = ("fluid.sph.smoothing_ratio=2.0",)
#: the thesis's wall model: the pressure layer solved in the pressure equation (issue 20)
LAYER = 'fluid.pressure.wall_model="pressure_layer"'


def stiff20(*sets: str) -> tuple:
    """A case of the stiff plate (:data:`STIFF`) under MPS at L/20 to 0.3 s with ``sets``."""
    return ("mps", 20, 0.3, (*STIFF, *sets))


#: key -> (fluid method, L / l0, end time in s[, extra --set overrides])
CASES = {
    "dsph20": ("delta-sph", 20, 0.3),
    "dsph40": ("delta-sph", 40, 0.3),
    "mps20": ("mps", 20, 0.3),
    "mps40": ("mps", 40, 0.3),
    "dsph80": ("delta-sph", 80, 0.3),
    "mps80": ("mps", 80, 0.3),
    "dsph20_long": ("delta-sph", 20, 0.6),
    "mps20_long": ("mps", 20, 0.6),
    "dsph20_pairs": ("delta-sph", 20, 0.3, PAIRS),
    "dsph40_pairs": ("delta-sph", 40, 0.3, PAIRS),
    "mps40_face": ("mps", 40, 0.3, FACE),
    "dsph40_face": ("delta-sph", 40, 0.3, FACE),
    "dsph20_wetted": ("delta-sph", 20, 0.3, WETTED),
    "dsph40_wetted": ("delta-sph", 40, 0.3, WETTED),
    "mps20_walls": ("mps", 20, 0.3, WALLS),
    "mps40_walls": ("mps", 40, 0.3, WALLS),
    "mps40_weakly": ("mps", 40, 0.3, WEAKLY),
    "mps20_stiff": ("mps", 20, 0.3, STIFF),
    "mps40_stiff": ("mps", 40, 0.3, STIFF),
    "dsph40_stiff": ("delta-sph", 40, 0.3, STIFF),
    # the stiff plate at L/20 under switches that change the pressure equation's per-step
    # source, the surface and the step count: does any of them take the noise away?
    "mps20_stiff_c0.05": stiff20("fluid.time_step.courant=0.05"),
    "mps20_stiff_c0.2": stiff20("fluid.time_step.courant=0.2"),
    "mps20_stiff_g0.001": stiff20("fluid.pressure.gamma=0.001"),
    "mps20_stiff_g0.05": stiff20("fluid.pressure.gamma=0.05"),
    "mps20_stiff_density": stiff20('fluid.surface.detector="density"'),
    "mps20_stiff_pzero": stiff20('fluid.surface.pressure="zero"'),
    # further switches on the stiff plate (2026-11-28): the CG tolerance (is the face's
    # coherent jump an unconverged smooth mode?), Khayyer & Gotoh's HS + ECS and HL, the
    # dynamic stabilisation, the thesis's wall model, the collision model off
    "mps20_stiff_tol1e-9": stiff20("fluid.pressure.tol=1e-9"),
    "mps20_stiff_hsecs": stiff20(
        'fluid.pressure.source_term="higher_order"', "fluid.pressure.error_compensation=true"
    ),
    "mps20_stiff_hl": stiff20('fluid.pressure.laplacian="higher_order"'),
    "mps20_stiff_ds": stiff20("fluid.pressure.dynamic_stabilization=0.8"),
    "mps20_stiff_layer": stiff20(LAYER),
    "mps20_stiff_nocoll": stiff20("fluid.collision.enabled=false"),
    "mps20_stiff_nocoll_ds": stiff20(
        "fluid.collision.enabled=false", "fluid.pressure.dynamic_stabilization=0.8"
    ),
    "mps40_stiff_layer": ("mps", 40, 0.3, (*STIFF, LAYER)),
    "mps20_layer": ("mps", 20, 0.3, (LAYER,)),
    "mps20_stiff_layer_tol5e-7": stiff20(LAYER, "fluid.pressure.tol=5e-7"),
    "mps20_stiff_tol5e-7": stiff20("fluid.pressure.tol=5e-7"),
    # a viscosity of δ-SPH's artificial one, nu = alpha h c0 / 8 (alpha 0.02, h 1.3 l0, c0
    # 33.8 m/s: 8e-4 m^2/s at L/20), and a quarter of it: is the white noise MPS's undamped
    # particle-scale velocity? (2026-11-28, twenty-first session)
    "mps20_stiff_nu8e-4": stiff20("fluid.viscosity=8e-4"),
    "mps20_stiff_nu2e-4": stiff20("fluid.viscosity=2e-4"),
    # the collision model's reach: each step kicks every approaching pair inside it by a fixed
    # share of its approach speed (a fixed impulse per step, as the noise's growth with the
    # step count reads)
    "mps20_stiff_cd0.6": stiff20("fluid.collision.distance=0.6"),
    "mps20_stiff_cd0.7": stiff20("fluid.collision.distance=0.7"),
    # the pressure equation's Laplacian on a shorter radius (4.01 l0 by default; the divergence
    # and the gradient are on 2.1 l0): the projection's overshoot on particle-scale modes
    "mps20_stiff_rp3.1": stiff20("fluid.kernel.re_pressure=3.1"),
    "mps20_stiff_rp2.1": stiff20("fluid.kernel.re_pressure=2.1"),
    # the source term's divergence averaged over the kernel (source_filter.py): the projection
    # is no longer asked for particle-scale divergence (2026-11-28, twenty-second session)
    "mps20_stiff_sfilt": stiff20('fluid.pressure.source_filter="kernel_average"'),
    "mps20_suction": ("mps", 20, 0.3, SUCTION),
    "mps40_suction": ("mps", 40, 0.3, SUCTION),
    "dsph20_h2": ("delta-sph", 20, 0.3, WIDE),
    "dsph40_h2": ("delta-sph", 40, 0.3, WIDE),
}
#: 0.1 s blocks after the first peak whose mean tip u_x is reported (the water piled up behind
#: the plate; docs/validation.md gives MPS's of an earlier fluid)
BLOCKS = ((0.3, 0.4), (0.4, 0.5), (0.5, 0.6))

SPH_TEXT = (
    """# written by validation/delta_sph_obstacle.py: scenarios/dam_break_elastic_obstacle_2d.toml
# with fluid.method = "delta-sph"; MPS's numerical tables ([fluid.pressure],
# fluid.time_step.courant) dropped, the default [fluid.sph], the momentum budget opted in,
# the tank's force reported as its pair exchange (boundary_force = "momentum_exchange")
[run]
end_time = 0.6

[output]
probe_interval = 1e-3
snapshot_interval = 0.0
checkpoint_interval = 0.1

[fluid]
method = "delta-sph"
dim = 2
spacing = 0.00365
density = 1000.0
viscosity = 1e-6
gravity = [0.0, -9.81]
momentum_budget = true
boundary_force = "momentum_exchange"

[fluid.sph]
smoothing_ratio = 1.3
gradient = "corrected"
integrator = "rk4"

[fluid.time_step]
dt_max = 2.5e-4

[[fluid.blocks]]
lower = [0.0, 0.0]
upper = [0.146, 0.292]

[[fluid.walls]]
name = "tank"
shape = "tank"
lower = [0.0, 0.0]
upper = [0.584, 1.0]

[structure]
initial_state = "rest"
record_interval = 1e-3

[structure.time]
dt = 2.5e-4

[[structure.members]]
name = "obstacle"
type = "beam"
start = [0.292, 0.0]
end = [0.292, 0.08]
elements = 10
bc = ["clamped", "free"]
kinematics = "corotational"
thickness = 0.012
axial = true
self_weight = true

[structure.members.material]
youngs_modulus = 1.0e6
poisson_ratio = 0.0
density = 2500.0

[coupling]
scheme = "implicit"

[coupling.mapping]
kind = "shape-function"

[coupling.acceleration]
kind = "iqn-ils"

[coupling.convergence]
relative_tolerance = 1e-3
absolute_tolerance = 1e-8
max_iterations = 30
on_divergence = "continue"

[[probes]]
name = "tip"
kind = "displacement"
target = "obstacle"
position = [0.292, 0.08]

[[probes]]
name = "obstacle_force"
kind = "force"
target = "obstacle"

[[probes]]
name = "front"
kind = "front"
axis = 0

[[probes]]
name = "obstacle_energy"
kind = "energy"
target = "obstacle"
"""
    + momentum_budget.INSTANT_PROBE
)


def write_scenarios() -> None:
    RESULTS.mkdir(parents=True, exist_ok=True)
    SPH_SCENARIO.write_text(SPH_TEXT)
    MPS_SCENARIO.write_text(
        "# written by validation/delta_sph_obstacle.py: "
        "scenarios/dam_break_elastic_obstacle_2d.toml + an instantaneous force probe\n"
        + SOURCE.read_text()
        + momentum_budget.INSTANT_PROBE
    )


def case_path(key: str) -> Path:
    return RESULTS / f"delta_sph_obstacle_{key}.h5"


def overrides(n: int, end_time: float, extra: tuple[str, ...] = ()) -> list[str]:
    return [
        f"fluid.spacing={L / n:.6g}",
        f"run.end_time={end_time}",
        "output.snapshot_interval=0",
        f"output.checkpoint_interval={min(0.1, end_time)}",
        *extra,
    ]


def budget(path: Path) -> dict:
    """Over the impact window, if the run kept a budget: the member's reported impulse, the
    residuals, the fluid's exchange with the member (what the fluid lost at it), the impulse of
    the load the member received (the force probe's interval means x 1 ms) and their gap
    relative to the exchange, and ``residual_load_rel``: residual_external with the member's
    received load in place of its reported impulse (dP - G + J_walls + J_load, over sum |J|;
    issue 20: the impulse the member receives against the momentum the fluid loses)."""
    with h5py.File(path, "r") as h5:
        if "momentum_budget" not in h5:
            return {}
        tf = h5["probes/obstacle_force/time"][:]
        ff = h5["probes/obstacle_force/value"][:]
    t0, t1 = IMPACT
    b = momentum_budget.window_sums(path, t0, t1)
    rep = b["patch_reported"]
    member = [k for k, p in enumerate(b["patches"]) if p.startswith("obstacle")]
    res = momentum_budget.residuals(b, rep)
    sel = (tf > t0 + 1e-9) & (tf <= t1 + 1e-9)
    dt = np.diff(tf, prepend=0.0)
    load = (ff[sel] * dt[sel, None]).sum(axis=0)  # N s/m, the interval means' impulse
    exch = b["patch_exchange"][member].sum(axis=0)
    received = rep.copy()
    received[member] = 0.0
    received[member[0]] = load
    res_load = momentum_budget.residuals(b, received)
    return {
        "member_impulse_x": float(rep[member, 0].sum()),
        "member_impulse_y": float(rep[member, 1].sum()),
        "residual_external_rel_x": res["residual_external_rel_x"],
        "residual_external_rel_y": res["residual_external_rel_y"],
        "residual_rel_x": res["residual_x"] / res["boundary_impulse_x"],
        "residual_rel_y": res["residual_y"] / res["boundary_impulse_y"],
        "member_exchange_x": float(exch[0]),
        "member_exchange_y": float(exch[1]),
        "member_load_x": float(load[0]),
        "member_load_y": float(load[1]),
        "load_gap_rel_x": float((load[0] - exch[0]) / abs(exch[0])),
        "load_gap_rel_y": float((load[1] - exch[1]) / abs(exch[0])),
        "residual_load_rel_x": res_load["residual_external_rel_x"],
        "residual_load_rel_y": res_load["residual_external_rel_y"],
    }


def analyse(path: Path) -> dict:
    with h5py.File(path, "r") as h5:
        tt = h5["probes/tip/time"][:]
        tip = h5["probes/tip/value"][:]
        tf = h5["probes/obstacle_force/time"][:]
        fx = h5["probes/obstacle_force/value"][:, 0]
        it = h5["coupling/iterations"][:]
        conv = h5["coupling/converged"][:]
        tc = h5["coupling/time"][:]
        ts = h5["structure/obstacle/time"][:]
        nodes = h5["structure/obstacle/nodes"][:] + h5["structure/obstacle/displacement"][:]
        row = {
            "wall_time_s": float(h5.attrs["wall_time"]),
            "steps": int(h5.attrs["steps"]),
            "particles": int(h5.attrs["particles"]),
            "t_end_s": float(tt[-1]),
        }
    k = int(np.argmax(tip[:, 0]))
    contact = np.nonzero(np.abs(fx) > CONTACT_FORCE)[0]
    peak_mean, ring_mean = momentum_budget.ringing(path, "obstacle_force", *IMPACT)
    peak_inst, ring_inst = momentum_budget.ringing(path, "force_last_step", *IMPACT)
    ring_fit, ring_residual = momentum_budget.ringing_split(path, "obstacle_force", *IMPACT)
    bad = np.nonzero(conv == 0)[0]
    chords = np.linalg.norm(np.diff(nodes, axis=1), axis=2)  # (time, elements), m
    rest = float(np.linalg.norm(np.diff(nodes[0], axis=0), axis=1).sum()) / chords.shape[1]
    j = int(np.argmax(chords[:, 0]))
    s_peak = int(np.argmin(np.abs(ts - tt[k])))
    for t0, t1 in BLOCKS:
        sel = (tt > t0 + 1e-9) & (tt <= t1 + 1e-9)
        done = tt[-1] >= t1 - 1e-9
        row[f"tip_mean_mm_{t0}_{t1}"] = 1e3 * float(tip[sel, 0].mean()) if done else np.nan
    row.update(
        {
            "tip_peak_mm": 1e3 * float(tip[k, 0]),
            "tip_peak_time_s": float(tt[k]),
            "tip_dy_at_peak_mm": 1e3 * float(tip[k, 1]),
            "first_contact_s": float(tf[contact[0]]) if contact.size else np.nan,
            "bottom_element_strain_max": float(chords[j, 0] / rest - 1.0),
            "bottom_element_strain_max_time_s": float(ts[j]),
            "chord_length_at_peak_mm": 1e3 * float(chords[s_peak].sum()),
            "force_peak_mean": peak_mean,
            "ringing_mean": ring_mean,
            "ringing_mean_fit11": ring_fit,
            "ringing_mean_residual": ring_residual,
            "force_peak_last_step": peak_inst,
            "ringing_last_step": ring_inst,
            "windows": int(it.size),
            "iterations_mean": float(it.mean()),
            "iterations_max": int(it.max()),
            "not_converged": int(bad.size),
            "not_converged_times_s": " ".join(f"{tc[i]:.4f}" for i in bad[:10]),
            **budget(path),
        }
    )
    return row


COLUMNS = [
    "case", "method", "L_over_l0", "spacing_m", "threads", "status", "particles", "t_end_s",
    "steps", "wall_time_s", "tip_peak_mm", "tip_peak_time_s", "tip_dy_at_peak_mm",
    "first_contact_s", "bottom_element_strain_max", "bottom_element_strain_max_time_s",
    "chord_length_at_peak_mm", "force_peak_mean", "ringing_mean", "ringing_mean_fit11",
    "ringing_mean_residual", "force_peak_last_step",
    "ringing_last_step", "windows", "iterations_mean", "iterations_max", "not_converged",
    "not_converged_times_s", *(f"tip_mean_mm_{a}_{b}" for a, b in BLOCKS), "member_impulse_x", "member_impulse_y", "residual_external_rel_x",
    "residual_external_rel_y", "residual_rel_x", "residual_rel_y", "member_exchange_x",
    "member_exchange_y", "member_load_x", "member_load_y", "load_gap_rel_x", "load_gap_rel_y",
    "residual_load_rel_x", "residual_load_rel_y",
]  # fmt: skip


#: the member's exchange against its load (δ-SPH only)
GAP_COLUMNS = (
    "member_exchange_x", "member_exchange_y", "member_load_x", "member_load_y", "load_gap_rel_x",
    "load_gap_rel_y", "residual_load_rel_x", "residual_load_rel_y",
)  # fmt: skip


def coupled_in_process(scenario: Path, sets: list[str]) -> tuple:
    """(fluid participant, initialised coupling scheme, scenario model) of ``scenario`` under
    ``sets``, built as run_coupled builds them: the diagnostics' in-process re-runs."""
    from mpsfem.coupler.coupling_scheme import create_scheme
    from mpsfem.fluid_methods import create_fluid_participant
    from mpsfem.scenario.loader import load_scenario
    from mpsfem.simulation import member_nodes
    from mpsfem.structure_fem.participant import StructureParticipant

    sc = load_scenario(scenario, sets).scenario
    st = StructureParticipant(sc.structure, base_dir=scenario.parent)
    names = [m for m, _ in member_nodes(sc)]
    fl = create_fluid_participant(
        sc.fluid, st.interface(), base_dir=scenario.parent, member_names=names
    )
    scheme = create_scheme(fl, st, sc.coupling, log=lambda m: None)
    scheme.initialize()
    return fl, scheme, sc


def load_centroid(key: str, t_end: float) -> tuple[list[dict], list[dict]]:
    """Where on the plate the fluid pushes, and the moment it bends the plate with: an
    in-process re-run of case ``key`` to ``t_end`` through the coupling scheme (as run_coupled
    builds it) that books, after each window, the last step's interface forces F_i
    (``read("forces")``) and
    - the moment of F_x about the clamp with the reference heights, sum F_x,i y_i (N m/m; its
      impulse over the F_x impulse is the height of the load's centroid);
    - the bending moment at the clamp with the displaced points (x_i, y_i) = reference +
      written displacement, M = sum (y_i - y_b) F_x,i - (x_i - x_b) F_y,i (clockwise positive,
      the sense the surge bends the plate: a downward F_y on the deflected plate adds to it).
    - under δ-SPH the whole pair exchange with the member's particles (``exchange_impulse_*``:
      the load under fluid.sph.structure_load = "exchange"; the load itself is its normal part,
      end caps pushed only); under MPS the load.
    Per span of CENTROID_SPANS the impulses (N s/m, N s) and the centroid height (m), and the
    per-window series (every 5th window). A diagnostic, not a results-file quantity."""
    import time

    method, n, _, *extra = CASES[key]
    scenario = SPH_SCENARIO if method == "delta-sph" else MPS_SCENARIO
    fl, scheme, sc = coupled_in_process(scenario, overrides(n, t_end, *extra))
    base = np.asarray(sc.structure.members[0].start, dtype=np.float64)
    ref = np.asarray(fl.interface().points) - base
    t, fx, fy, m_ref, m_bend, ex = [], [], [], [], [], []
    solver = getattr(fl, "solver", None)
    exchange = getattr(solver, "reaction_step", None) is not None and hasattr(fl, "_slot")
    tic = time.perf_counter()
    while scheme.t < t_end - 1e-9:
        scheme.advance_window()
        f = fl.read("forces")
        r = ref + fl._d  # the displaced interface points (the written displacement)
        t.append(scheme.t)
        fx.append(f[:, 0].sum())
        fy.append(f[:, 1].sum())
        m_ref.append(float(f[:, 0] @ ref[:, 1]))
        m_bend.append(float(f[:, 0] @ r[:, 1] - f[:, 1] @ r[:, 0]))
        # δ-SPH: the whole pair exchange with the member's particles (the load before
        # fluid.sph.structure_load = "normal"), for the part the load leaves out
        ex.append(solver.reaction_step[fl._slot].sum(axis=0) if exchange else f.sum(axis=0))
    wall = time.perf_counter() - tic
    t, fx, fy, m_ref, m_bend, ex = (np.array(a) for a in (t, fx, fy, m_ref, m_bend, ex))
    window = float(scheme.window)
    rows = []
    for t0, t1 in CENTROID_SPANS:
        sel = (t > t0 + 1e-12) & (t <= t1 + 1e-12)
        jx, jy = window * fx[sel].sum(), window * fy[sel].sum()
        jm, jb = window * m_ref[sel].sum(), window * m_bend[sel].sum()
        rows.append(
            {
                "case": key,
                "method": method,
                "L_over_l0": n,
                "t0_s": t0,
                "t1_s": t1,
                "impulse_x": jx,
                "impulse_y": jy,
                "moment_impulse_ref": jm,
                "centroid_height_m": jm / jx,
                "bending_moment_impulse": jb,
                "exchange_impulse_x": window * ex[sel, 0].sum(),
                "exchange_impulse_y": window * ex[sel, 1].sum(),
                "wall_time_s": wall,
            }
        )
    series = [
        {"case": key, "t_s": t[i], "fx": fx[i], "fy": fy[i], "m_ref": m_ref[i], "m_bend": m_bend[i]}
        for i in range(4, t.size, 5)
    ]
    return rows, series


def axial_split(key: str) -> list[dict]:
    """Where δ-SPH's vertical load on the plate comes from (docs/validation_delta_sph_coupled.md,
    "Axial load"): an in-process re-run of δ-SPH case ``key`` to AXIAL_SPAN[1] with
    fluid.sph.structure_load = "exchange" (the whole pair exchange, the load before the normal
    load) that, every AXIAL_EVERY-th window from AXIAL_SPAN[0] on, re-evaluates the right-hand
    side at the window's end and rebuilds each structure particle's reaction pair by pair,
    F_j = sum_i V_i (p_i + p_j) M_i grad_i W_ij V_j (delta_sph.wall_reaction). Sampled impulses
    (N s/m, sample x AXIAL_EVERY windows) of F_y: whole; with M_i = I; M_i's off-diagonal part;
    per interface point its part tangential to the point's normal (rows ``point``) and in
    total; the normal projection of the face points; the corner points whole. Also the corner
    particles' lowest Adami pressure (Pa). One row per interface point plus a row ``total``."""

    method, n, *_ = CASES[key]
    if method != "delta-sph":
        raise SystemExit(f"--axial takes δ-SPH cases, not {key}")
    extra = ['fluid.sph.structure_load="exchange"']
    fl, scheme, _ = coupled_in_process(SPH_SCENARIO, [*overrides(n, AXIAL_SPAN[1]), *extra])
    s = fl.solver
    nf, ext, n_if = s.n_fluid, s.ext_rows, fl.surface.n_interface
    dt_s = AXIAL_EVERY * float(scheme.window)
    pts = fl.interface().points
    nrm_ref = fl.interface().normals
    is_face = (np.abs(nrm_ref[:, 0]) > 1.0 - 1e-9) | (np.abs(nrm_ref[:, 1]) > 1.0 - 1e-9)
    acc = {k: 0.0 for k in ("whole", "plain", "offdiag", "tangential", "faces_normal", "corners")}
    tang = np.zeros(n_if)
    p_corner_min = 0.0
    w = 0
    while scheme.t < AXIAL_SPAN[1] - 1e-9:
        scheme.advance_window()
        w += 1
        if scheme.t < AXIAL_SPAN[0] + 1e-9 or w % AXIAL_EVERY:
            continue
        s.rhs()  # at the window's end (the next step starts with its own right-hand side)
        nb = s._last_neighbours
        i = np.repeat(np.arange(nb.indptr.size - 1), np.diff(nb.indptr))
        j = nb.indices
        keep = (i < nf) & (s.ext_slot[j] >= 0)
        i, j = i[keep], j[keep]
        d = s.pos[i] - s.pos[j]
        t = np.clip(1.0 - 0.5 * np.linalg.norm(d, axis=1) * s.inv_h, 0.0, None)
        plain = (s.grad_coef * t**3 * s.vol[j] * (s.p[i] + s.p[j]) * s.vol[i])[:, None] * d
        whole = np.einsum("kab,kb->ka", s.M[i], plain)  # the reaction on j, as wall_reaction
        acc["whole"] += dt_s * whole[:, 1].sum()
        acc["plain"] += dt_s * plain[:, 1].sum()
        acc["offdiag"] += dt_s * (s.M[i][:, 1, 0] * plain[:, 0]).sum()
        reac = np.zeros((ext.size, 2))
        np.add.at(reac, s.ext_slot[j], whole)
        r = reac[fl._slot]
        f = np.stack([np.bincount(fl._target, weights=r[:, a], minlength=n_if) for a in (0, 1)], 1)
        nrm = s.normal[fl._if_rows]
        fn = np.einsum("ka,ka->k", f, nrm)[:, None] * nrm
        tang += dt_s * (f - fn)[:, 1]
        acc["faces_normal"] += dt_s * fn[is_face, 1].sum()
        acc["corners"] += dt_s * f[~is_face, 1].sum()
        if (~is_face).any():
            p_corner_min = min(p_corner_min, float(s.p[fl._if_rows[~is_face]].min()))
    acc["tangential"] = float(tang.sum())
    base = {"case": key, "t0_s": AXIAL_SPAN[0], "t1_s": AXIAL_SPAN[1], "every": AXIAL_EVERY}
    rows = [{**base, "row": "total", "x_m": np.nan, "y_m": np.nan, **acc,
             "corner_p_min_Pa": p_corner_min}]  # fmt: skip
    for k in np.lexsort((pts[:, 1], pts[:, 0])):
        rows.append({**base, "row": "point", "x_m": pts[k, 0], "y_m": pts[k, 1],
                     "tangential": tang[k]})  # fmt: skip
    return rows


def noise_map(key: str) -> tuple[dict, list[dict]]:
    """Where the ringing comes from: an in-process re-run of case ``key`` to the end of
    NOISE_SPAN that books after each coupling window the last step's interface force on every
    member node (``read("forces")``, N/m) and, under MPS, how many fluid particles within
    2.1 l0 of a member particle there are and how many of them the detector flags as free
    surface. Over NOISE_SPAN, from the per-window node forces F_x,k (window-to-window jumps J):
    per node the mean and the RMS jump; for the sum, its peak and RMS jump / peak, the ratio
    var(sum_k J_k) / sum_k var(J_k) (1 for nodes that jump independently, the node count for
    a face that jumps as one), the mean correlation of neighbouring nodes' jumps, the lag-1
    autocorrelation of the sum's jumps' source (the sum minus a 41-window cubic
    Savitzky-Golay fit: 0 for white noise), the share of that residual's power above 500 Hz,
    and the correlation of |J| with the change in the number of surface-flagged fluid
    particles next to the member. A diagnostic (issue 20, the ringing), not a results-file
    quantity."""
    from scipy.signal import savgol_filter

    method, n, _, *extra = CASES[key]
    scenario = SPH_SCENARIO if method == "delta-sph" else MPS_SCENARIO
    t0, t1 = NOISE_SPAN
    fl, scheme, _ = coupled_in_process(scenario, overrides(n, t1, *extra))
    solver = fl.solver
    flags = getattr(solver, "free_surface", None) if method == "mps" else None
    heights = np.asarray(fl.interface().points)[:, 1]
    t, fx, near, surf = [], [], [], []
    while scheme.t < t1 - 1e-9:
        scheme.advance_window()
        if scheme.t < t0 - 1e-9:
            continue
        t.append(scheme.t)
        fx.append(fl.read("forces")[:, 0].copy())
        if flags is not None:
            fluid = solver.kind == 0
            member = (solver.kind == 3) | (solver.kind == 4)
            d = np.linalg.norm(
                solver.pos[fluid][:, None, :] - solver.pos[member][None, :, :], axis=2
            ).min(axis=1)
            close = d < 2.1 * solver.l0
            near.append(int(close.sum()))
            surf.append(int((flags[fluid].astype(bool) & close).sum()))
    t, fx = np.array(t), np.array(fx)
    # nodes the fluid reaches: a load above 1e-3 of the largest node's (the member's other face
    # and its dry nodes carry none, or the fluid's round-off through the mapping)
    top = np.abs(fx).max(axis=0)
    wet = top > 1e-3 * top.max()
    fx = fx[:, wet]
    total = fx.sum(axis=1)
    jumps = np.diff(fx, axis=0)
    jt = np.diff(total)
    peak = float(np.abs(total).max())
    adjacent = [np.corrcoef(jumps[:, k], jumps[:, k + 1])[0, 1] for k in range(fx.shape[1] - 1)]
    resid = total - savgol_filter(total, 41, 3)
    power = np.abs(np.fft.rfft(resid)) ** 2
    freq = np.fft.rfftfreq(resid.size, float(np.mean(np.diff(t))))
    summary = {
        "case": key,
        "method": method,
        "L_over_l0": n,
        "windows": int(t.size),
        "wet_nodes": int(wet.sum()),
        "force_peak": peak,
        "jump_rms_over_peak": float(np.sqrt(np.mean(jt**2)) / peak),
        "variance_ratio": float(np.var(jt) / np.var(jumps, axis=0).sum()),
        "adjacent_jump_correlation": float(np.nanmean(adjacent)),
        "residual_lag1_autocorrelation": float(np.corrcoef(resid[:-1], resid[1:])[0, 1]),
        "residual_power_above_500Hz": float(power[freq >= 500.0].sum() / power.sum()),
        "near_fluid_mean": float(np.mean(near)) if near else np.nan,
        "near_surface_flagged_mean": float(np.mean(surf)) if surf else np.nan,
        "jump_vs_flag_change_correlation": (
            float(np.corrcoef(np.abs(jt), np.abs(np.diff(surf)))[0, 1]) if surf else np.nan
        ),
    }
    nodes = [
        {
            "case": key,
            "node_height_m": float(h),
            "mean_fx": float(fx[:, k].mean()),
            "jump_rms": float(np.sqrt(np.mean(jumps[:, k] ** 2))),
        }
        for k, h in enumerate(heights[wet])
    ]
    return summary, nodes


def _read(path: Path) -> list[dict]:
    return read_csv(path) if path.is_file() else []


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    case_runner.add_run_options(ap)
    ap.add_argument("--cases", nargs="+", choices=list(CASES), default=list(CASES))
    ap.add_argument(
        "--centroid",
        action="store_true",
        help="only the load-centroid diagnostic of --cases (in-process re-runs to 0.25 s) -> "
        f"{CENTROID_CSV.name}",
    )
    ap.add_argument(
        "--axial",
        action="store_true",
        help="only the split of δ-SPH's vertical load on the plate over 0.12-0.17 s (in-process "
        f"re-runs with the whole pair exchange) of --cases -> {AXIAL_CSV.name}",
    )
    ap.add_argument(
        "--noise-map",
        action="store_true",
        help="only the ringing's node-by-node diagnostic of --cases (in-process re-runs to "
        f"{NOISE_SPAN[1]} s) -> {NOISE_CSV.name}",
    )
    args = ap.parse_args()
    if args.noise_map:
        write_scenarios()
        rows = [r for r in _read(NOISE_CSV) if r["case"] not in args.cases]
        for key in args.cases:
            summary, nodes = noise_map(key)
            rows += [summary, *nodes]
            print(
                ", ".join(
                    f"{k} {v:.3g}" if isinstance(v, float) else f"{k} {v}"
                    for k, v in summary.items()
                )
            )
        rows.sort(key=lambda r: list(CASES).index(r["case"]))  # stable: summary, then nodes
        write_csv(
            rows,
            NOISE_CSV,
            list(dict.fromkeys(k for r in rows for k in r)),
            comment="elastic obstacle: the ringing node by node, per coupling window over "
            f"{NOISE_SPAN[0]}-{NOISE_SPAN[1]} s (validation/delta_sph_obstacle.py --noise-map; "
            "one summary row per case, then its wetted nodes)",
        )
        return 0
    if args.axial:
        write_scenarios()
        rows = [r for r in _read(AXIAL_CSV) if r["case"] not in args.cases]
        for key in args.cases:
            new = axial_split(key)
            rows += new
            tot = new[0]
            print(
                f"{key}: F_y impulse {tot['whole']:+.3f} N s/m (M = I: {tot['plain']:+.3f}, M "
                f"off-diagonal {tot['offdiag']:+.3f}); tangential {tot['tangential']:+.3f}; "
                f"faces' normal part {tot['faces_normal']:+.3f}, corners whole "
                f"{tot['corners']:+.3f}; corner p min {tot['corner_p_min_Pa']:.0f} Pa"
            )
        write_csv(
            rows,
            AXIAL_CSV,
            list(dict.fromkeys(k for r in rows for k in r)),
            comment="elastic obstacle, δ-SPH with the whole pair exchange: sampled impulses "
            "(N s/m) of the plate's F_y over 0.12-0.17 s split (validation/delta_sph_obstacle.py "
            "--axial)",
        )
        return 0
    if not args.analyse_only:
        write_scenarios()
    if args.centroid:  # rows of cases not re-run are kept from the CSVs
        rows = [r for r in _read(CENTROID_CSV) if r["case"] not in args.cases]
        series = [r for r in _read(CENTROID_SERIES_CSV) if r["case"] not in args.cases]
        for key in args.cases:
            r, sr = load_centroid(key, IMPACT[1])
            rows += r
            series += sr
        write_csv(
            series,
            CENTROID_SERIES_CSV,
            list(series[0]),
            comment="elastic obstacle: last-step interface force sums (N/m) and moments about "
            "the clamp (N m/m) every 5th window (validation/delta_sph_obstacle.py --centroid)",
        )
        columns = list(dict.fromkeys(k for r in rows for k in r))  # kept rows may lack some
        write_csv(
            rows,
            CENTROID_CSV,
            columns,
            comment="elastic obstacle: impulse of the last-step interface force F_x and of its "
            "moment about the base per span; centroid = their ratio (validation/"
            "delta_sph_obstacle.py --centroid)",
        )
        for r in (r for r in rows if r["case"] in args.cases):
            print(
                f"{r['case']:7} {r['t0_s']:.2f}-{r['t1_s']:.2f} s: J_x {r['impulse_x']:7.3f} "
                f"N s/m, centroid {1e3 * r['centroid_height_m']:5.1f} mm, J_y "
                f"{r['impulse_y']:7.3f} N s/m, bending {r['bending_moment_impulse']:7.4f} N s, "
                f"exchange J_y {r['exchange_impulse_y']:7.3f} N s/m"
            )
        return 0
    rows = []
    # a case neither selected nor on disk (results files are not kept in git) keeps its CSV row
    kept = {r["case"]: r for r in _read(CSV)}
    kept_cases: list[str] = []
    for key, (method, n, t_end, *extra) in CASES.items():  # cases not selected: read, not run
        scenario = SPH_SCENARIO if method == "delta-sph" else MPS_SCENARIO
        out = case_path(key)
        if key not in args.cases and not out.is_file() and key in kept:
            rows.append(kept[key])
            kept_cases.append(key)
            continue
        status = case_runner.case_status(
            scenario,
            out,
            overrides(n, t_end, *extra),
            args.threads,
            args.analyse_only or key not in args.cases,
            args.retry_failed,
            f"[{key}]",
        )
        row = {
            "case": key,
            "method": method,
            "L_over_l0": n,
            "spacing_m": float(f"{L / n:.6g}"),
            "threads": args.threads,
            "status": status or "missing",
        }
        if status == "finished":
            row.update(analyse(out))
        if method == "mps":  # its pair exchange misses most of the push (non-antisymmetric
            for key in GAP_COLUMNS:  # gradient, docs/fluid.md): no gap to the load to report
                row.pop(key, None)
        rows.append(row)
    write_csv(
        rows,
        CSV,
        COLUMNS,
        comment="elastic obstacle, δ-SPH beside MPS (validation/delta_sph_obstacle.py); tip in "
        "mm, forces N/m, impulses N s/m; impact window 0.12-0.25 s",
    )
    print(
        f"{'case':7} {'tip mm':>7} {'at s':>6} {'F peak':>7} {'ring':>5} {'it mean':>7} "
        f"{'max':>4} {'nc':>3} {'res x':>7} {'res y':>7} {'wall s':>7}"
    )
    for r in rows:
        if r["case"] in kept_cases:
            print(f"{r['case']:7} (row kept from {CSV.name}: no results file here)")
            continue
        if "tip_peak_mm" not in r:
            print(f"{r['case']:7} {r['status']}")
            continue
        print(
            f"{r['case']:7} {r['tip_peak_mm']:7.2f} {r['tip_peak_time_s']:6.3f} "
            f"{r['force_peak_mean']:7.1f} {r['ringing_mean']:5.2f} {r['iterations_mean']:7.2f} "
            f"{r['iterations_max']:4d} {r['not_converged']:3d} "
            f"{r.get('residual_external_rel_x', np.nan):7.3f} "
            f"{r.get('residual_external_rel_y', np.nan):7.3f} {r['wall_time_s']:7.1f}"
        )
    print(f"wrote {CSV}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
