"""Coupling stress sweeps, one factor at a time (issue 21): mass ratio, Young's modulus, window.

    .venv/bin/python benchmarks/bench_coupling_stress.py [--only plate_ratio,obstacle_E,...]
        [--acceleration iqn-imvj] [--out benchmarks/results/coupling_stress.csv]

Sweeps (each row one coupled MPS run; every other setting is the scenario's own):

* ``plate_ratio``: scenarios/hydrostatic_plate_2d.toml at l0 = 0.05 m (as the added-mass sweep
  of bench_coupling_overhead.py), 0.03 s = 150 windows of 0.2 ms, the plate's density set so
  that the mass ratio (rho_s h) / (rho_w H) (h = 0.05 m, H = 2 m) is 10, 1, 0.1, 1e-2, 1e-3,
  1e-4; self-weight off.
* ``plate_window``: the same plate at its own mass ratio (2.7e3 x 0.05 / 2e3 = 0.0675), windows
  of 0.25, 1 and 4 ms (structure dt 0.25 ms, so it sub-cycles 1, 4 and 16 steps), 0.04 s.
* ``obstacle_ratio``: scenarios/dam_break_elastic_obstacle_2d.toml at l0 = L/20 = 0.0073 m,
  shortened to 0.17 s (the surge reaches the plate at about 0.15 s: the first-contact windows,
  where wet/dry switching is, are in; the first tip peak, at about 0.2 s, is not), mass ratio
  (h = 0.012 m, H = 0.292 m) 10, 0.103 (the scenario's), 1e-2, 1e-3, 1e-4; self-weight off
  (1e-3 added 2026-11-27; coupling_stress.csv predates it). A run with ``--set`` overrides has
  them in a settings column (e.g. benchmarks/results/coupling_stress_wc_mps.csv).
* ``obstacle_E``: the same obstacle run at its own mass ratio with E = 1e5, 1e6 (the
  scenario's), 1e8, 2e11 Pa.
* ``plate_fictitious``: the plate of ``plate_ratio`` at mass ratio 1e-3 and 1e-4 with the
  member's ``fictitious_mass`` at 0.3, 1 and 3 times the estimate m_a = rho_w (2H/3 + L/(6 pi)
  tanh(2 pi H / L)) = 1386 kg/m^2 (the added mass of the clamped plate's first mode, sin^2
  shape, in the walled tank with a free surface: docs/coupler.md, "Fictitious mass"); the
  factor column is the multiple of the estimate. Not in the default set (``--only
  plate_fictitious``).
* ``obstacle_fictitious``: the obstacle of ``obstacle_ratio`` at mass ratio 1e-2 and 1e-4 with
  ``fictitious_mass`` 0 (baseline), 0.3, 1, 3 x the estimate 2 rho_w l / pi = 51 kg/m^2 (one wetted face,
  quarter-wave first mode: :func:`obstacle_added_mass`). Not in the default set.
* ``--set KEY=VALUE`` adds an override to every run, e.g. ``--set
  'coupling.convergence.relative_to="window_motion"'`` (the rows of
  benchmarks/results/coupling_stress_fictitious_window_motion.csv: ``--only
  plate_fictitious --values 0.3,1.0`` and ``--only obstacle_fictitious --values 0.0,1.0,3.0``,
  both ``--acceleration aitken``).
* ``--ratios 0.01,...`` keeps the runs of those mass ratios. When every run is a fictitious one
  the CSV gains the columns peak_time_s (the obstacle tip's largest dx), wet_windows (windows in
  which M_f acted), force_error_max (the largest ``/coupling/fictitious_force_error`` of an
  accepted window) and settings (the ``--set`` overrides): the rows with the force-error
  criterion and wetted-node M_f (task H1) are in
  benchmarks/results/coupling_stress_fictitious_force.csv (``--only obstacle_fictitious
  --ratios 0.01 --acceleration aitken --out ...``; ``--only plate_fictitious --ratios 0.0001
  ... --append``, with ``--set coupling.convergence.fictitious_force_tolerance=0.05`` for the
  5e-2 rows). ``--append`` refuses a CSV with other columns.
* ``plate_shaped`` / ``obstacle_shaped`` (task H1; not in the default set): the plate at mass
  ratio 1e-3 and 1e-4 with ``fictitious_mass_model = "potential_flow"`` and ``fictitious_mass``
  (then a factor c) 0.25, 0.5, 1; the obstacle at 1e-2, 1e-3 (task H2) and 1e-4 with c = 0
  (no M_f), 0.25, 0.5, 1. Their own CSV, benchmarks/results/coupling_stress_shaped.csv, with the extra columns
  iterations_mean_wet / not_converged_wet (the windows in which M_f acted). ``--wet-pressure
  Pa`` sets ``fictitious_wet_pressure``, ``--force-tolerance`` the coupling's
  ``fictitious_force_tolerance``, ``--keep-h5 DIR`` keeps each run's results file, and
  ``--probe-tank-depth H`` (a probe, :func:`_probe_tank_operator`) replaces the potential-flow
  model's operator in process by the tank-bottom one (structure_fem/added_mass_tank.py).
  Rows: docs/validation_coupling_stress.md, "The shaped fictitious mass on the plate and the
  obstacle". Task H2's rows add ``--set coupling.convergence.accept_unconverged="best"`` and
  ``--set coupling.convergence.retreat_predictor=true`` (the "settings" column), and
  ``--trace FILE`` (a probe, :func:`_install_trace`) records every coupling iteration from
  ``--trace-from`` s on; ``--summarize-trace FILE`` sorts a trace's unconverged windows by
  cause (:func:`summarize_trace`; docs/validation_coupling_stress.md, "Mass ratio 1e-4 on the
  obstacle: what the iterations do").
* ``plate_map`` (``--only plate_map``; :func:`plate_map_probe`): the added mass the MPS window
  presents to the plate along interface shapes and as a whole matrix, against the impact and
  tank operators (benchmarks/results/coupling_stress_shaped_plate_map.csv, ..._modes.csv;
  ``--map-spacing`` another l0, its own CSV); ``obstacle_map`` the same on the obstacle's
  wetted run at t = 0.14 s (``--map-windows``) against the impact operator
  (..._obstacle_map.csv).
* ``--set fluid.pressure.structure_suction=true`` (negative pressure next to the member away
  from the free surface): ``--only obstacle_ratio --ratios 0.103,0.0001,0.01 --out
  benchmarks/results/coupling_stress_suction.csv``, and the H2 setting's row appended to
  coupling_stress_shaped.csv (docs/fluid.md, "Suction at structure members").
* ``--set fluid.collision.ramp=0.1`` (a collision impulse continuous in the pair distance, so a
  member's contact load is continuous in its displacement): H2's ``obstacle_shaped`` setting at
  1e-2 (L/20 and L/40), 1e-3 and 1e-4 to 0.3 s, rows appended to coupling_stress_shaped.csv;
  ``--only obstacle_ratio --ratios 0.01`` with it in coupling_stress_ramp.csv
  (docs/validation_coupling_stress.md, "A collision that fades in").
* ``--set "coupling.acceleration.relaxation_bounds=[0.05,1.5]"`` (a floor under Aitken's factor,
  which collapses toward zero in the windows the 1e-4 obstacle leaves unconverged) and
  ``--set fluid.pressure.tol=5e-7`` / ``2e-6`` (other realisations of the same flow): H2's
  ``obstacle_shaped`` setting at 1e-4 with the ramp 0.5, the bounds none, [0.02, 1.5],
  [0.05, 1.5], [0.05, 20] and [0.1, 1.5]; at 1e-2 and 1e-3 with the ramp 0.1; rows appended to
  coupling_stress_shaped.csv (docs/validation_coupling_stress.md, "Aitken's collapse").
* the same 1e-4 setting with the load as a pair exchange (``--set
  'fluid.pressure.gradient="tanaka"' --set fluid.pressure.pressure_courant=0.25 --set
  'fluid.boundary_force="momentum_exchange"'``) and weakly compressible (``--set
  fluid.pressure.compressibility=K --set fluid.pressure.shifting=0.1``, K 8.75e-7 / 1.7e-6 /
  3.5e-6, with the bounds [0.05, 1.5] or [0.05, 20]); rows appended to
  coupling_stress_shaped.csv (docs/validation_coupling_stress.md, "Weakly compressible MPS at
  mass ratio 1e-4").
* finer spacings at mass ratio 1e-4 / 1e-2: ``--set fluid.spacing=0.00365`` (L/40) or
  ``0.001825`` (L/80) on ``--only obstacle_ratio`` (rows in
  benchmarks/results/coupling_stress_fine.csv) and on H2's ``obstacle_shaped`` setting (rows
  appended to coupling_stress_shaped.csv).
* ``obstacle_sph_ratio`` (``--only obstacle_sph_ratio``; not in the default set): the obstacle
  of ``obstacle_ratio`` under the δ-SPH fluid (validation/results/delta_sph_obstacle.toml, as
  validation/delta_sph_obstacle.py writes it: Adami walls, whose extrapolated pressure can pull)
  at mass ratio 10, 0.103, 1e-2, 1e-3 and 1e-4, without the MPS-only surface freeze (issue 21: is the
  MPS fluid's push-only, white-noise load what stops the windows at 1e-4?); ``plate_sph_ratio``
  the plate of ``plate_ratio`` the same way (``fluid.method = "delta-sph"`` on its scenario);
  ``obstacle_sph_E`` and ``plate_sph_window`` the Young's modulus and window sweeps under δ-SPH.
  ``--end-time`` runs every selected run to another end (the obstacle's to 0.3 s, past its
  first tip peak). Rows: benchmarks/results/coupling_stress_sph.csv (``--out``), with the
  overrides in their settings column; docs/validation_coupling_stress.md, "Under the δ-SPH
  fluid" (and "Under δ-SPH: Aitken with a floor": ``--acceleration aitken`` with the shaped
  fictitious mass and ``coupling.acceleration.relaxation_bounds`` through ``--set``, realisations
  by ``fluid.sph.cfl``).
* ``mock_fictitious`` (``--only mock_fictitious``, its own CSV
  benchmarks/results/coupling_stress_mock_fictitious.csv; see :func:`mock_sweep`): the FEM beam
  against the added-mass mock at added / structure mass 1e4, with and without fictitious mass.

All runs: implicit coupling with ``--acceleration`` (default iqn-imvj, its defaults), rtol 1e-3,
at most 30 iterations, the scenario's ``on_divergence = "continue"`` (a window not converged is
accepted, recorded in /coupling/converged and counted here), and the discrete surface/wet-dry
flags frozen per window with the "settled" rule (``fluid.surface.freeze_in_coupling_window``).
A run that stops reports the error's type and the start of its message; a run whose
displacement is not finite would be reported as such (none may be silent or NaN). The interface
displacement is bounded by ``coupling.convergence.max_displacement`` (a tenth of the plate's
span, the obstacle's length): a run flung beyond it by accepted unconverged windows stops with a
named CouplingDivergedError.

Writes one CSV row per run as it finishes (benchmarks/results/coupling_stress.csv): case,
factor, value, mass_ratio, verdict, windows, iterations mean / max, windows_not_converged,
displacement (plate: mean mid deflection over the second half; obstacle: peak tip dx), wall_s.
"""

from __future__ import annotations

import argparse
import csv
import itertools
import math
import os
import sys
import tempfile
import time
from pathlib import Path

import h5py
import numpy as np
import scipy.linalg as sla

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "src"))

PLATE = ROOT / "scenarios" / "hydrostatic_plate_2d.toml"
OBSTACLE = ROOT / "scenarios" / "dam_break_elastic_obstacle_2d.toml"
#: the obstacle under the δ-SPH fluid, as validation/delta_sph_obstacle.py writes it
OBSTACLE_SPH = ROOT / "validation" / "results" / "delta_sph_obstacle.toml"
RHO_W = 1000.0

# (scene, H, h, probe, component, spacing, end time, displacement bound): the bound, set as
# coupling.convergence.max_displacement, stops a run whose interface moves beyond what the
# member can (a tenth of the plate's 1 m span; the obstacle's length, 0.08 m) with a named
# CouplingDivergedError instead of letting accepted unconverged windows fling it
SCENES = {
    "plate": (PLATE, 2.0, 0.05, "mid_deflection", 1, 0.05, 0.03, 0.1),
    "obstacle": (OBSTACLE, 0.292, 0.012, "tip", 0, 0.0073, 0.17, 0.08),
    "obstacle_sph": (OBSTACLE_SPH, 0.292, 0.012, "tip", 0, 0.0073, 0.17, 0.08),
}
SCENES["plate_sph"] = SCENES["plate"]  # the same scenario, fluid.method set by SPH_SCENES
#: scenes under the δ-SPH fluid: their own overrides, and no MPS surface flags to freeze
SPH_SCENES = {"obstacle_sph": [], "plate_sph": ['fluid.method="delta-sph"']}


def plate_added_mass(H: float = 2.0, L: float = 1.0) -> float:
    """Added mass (kg/m^2) of the clamped plate's first mode, w = sin^2(pi x / L), under a
    water column of depth H between rigid walls L apart with a free surface (p = 0 there):
    w = 1/2 - 1/2 cos(2 pi x / L); the uniform part lifts the column (rho H per m^2), the cosine
    part carries rho tanh(k H) / k (k = 2 pi / L; incompressible potential flow, p = 0 on the
    free surface: the limit of frequencies far above sloshing; derived in docs/coupler.md,
    "Fictitious mass"); Rayleigh quotient over int w^2 = 3 L / 8:
    m_a = rho (H L / 4 + L^2 tanh(k H) / (16 pi)) / (3 L / 8) = rho (2 H / 3 + L tanh(k H) /
    (6 pi))."""
    return RHO_W * (2.0 * H / 3.0 + L * math.tanh(2.0 * math.pi * H / L) / (6.0 * math.pi))


def obstacle_added_mass(length: float = 0.08) -> float:
    """Added mass (kg/m^2) of the obstacle's first mode, wetted on one face: a clamped-free
    wall of length 0.08 m bends as about a quarter wave, wavenumber k = pi / (2 length); a
    sinusoidal normal motion of wavenumber k of a plane face against a deep liquid carries rho /
    k per m^2 (incompressible potential flow decaying as exp(-k n)): m_a = 2 rho length / pi
    (51 kg/m^2). Rough: the surge wets only part of the wall and only after about 0.15 s."""
    return RHO_W * 2.0 * length / math.pi


def sweeps() -> list[tuple[str, str, str, float, list[str], float | None]]:
    """(sweep, scene, factor, value, --set overrides, end time or None) of every run."""
    out = []
    for r in (10.0, 1.0, 0.1, 1e-2, 1e-3, 1e-4):
        rho = r * RHO_W * 2.0 / 0.05
        sets = [f"structure.members.0.material.density={rho!r}"]
        out.append(("plate_ratio", "plate", "mass_ratio", r, sets, None))
        out.append(("plate_sph_ratio", "plate_sph", "mass_ratio", r, sets, None))
    for T in (2.5e-4, 1e-3, 4e-3):
        sets = ["structure.time.dt=0.00025", f"coupling.window={T!r}"]
        out.append(("plate_window", "plate", "window_s", T, sets, 0.04))
        out.append(("plate_sph_window", "plate_sph", "window_s", T, sets, 0.04))
    for r in (10.0, 0.103, 1e-2, 1e-3, 1e-4):
        rho = r * RHO_W * 0.292 / 0.012
        sets = [f"structure.members.0.material.density={rho!r}"]
        out.append(("obstacle_ratio", "obstacle", "mass_ratio", r, sets, None))
    for r in (10.0, 0.103, 1e-2, 1e-3, 1e-4):  # the same under δ-SPH: a fluid that can pull
        rho = r * RHO_W * 0.292 / 0.012
        sets = [f"structure.members.0.material.density={rho!r}"]
        out.append(("obstacle_sph_ratio", "obstacle_sph", "mass_ratio", r, sets, None))
    for E in (1e5, 1e6, 1e8, 2e11):
        sets = [f"structure.members.0.material.youngs_modulus={E!r}"]
        out.append(("obstacle_E", "obstacle", "youngs_modulus_Pa", E, sets, None))
        out.append(("obstacle_sph_E", "obstacle_sph", "youngs_modulus_Pa", E, sets, None))
    m_a = plate_added_mass()
    for r in (1e-3, 1e-4):
        rho = r * RHO_W * 2.0 / 0.05
        for f in (0.3, 1.0, 3.0):
            sets = [
                f"structure.members.0.material.density={rho!r}",
                f"structure.members.0.fictitious_mass={f * m_a!r}",
            ]
            out.append(("plate_fictitious", "plate", "fictitious_mass_x_estimate", f, sets, None))
    m_a = obstacle_added_mass()
    for r in (1e-2, 1e-4):
        rho = r * RHO_W * 0.292 / 0.012
        for f in (0.0, 0.3, 1.0, 3.0):  # 0: the same run without (a same-code baseline)
            sets = [
                f"structure.members.0.material.density={rho!r}",
                f"structure.members.0.fictitious_mass={f * m_a!r}",
            ]
            out.append(
                ("obstacle_fictitious", "obstacle", "fictitious_mass_x_estimate", f, sets, None)
            )
    # the shaped M_f (task H1, issue 21): fictitious_mass_model = "potential_flow", the
    # fictitious_mass a factor c on the patch's potential-flow added-mass operator
    # (structure_fem/added_mass_potential.py); c = 0 on the obstacle: the same run without M_f
    for scene, H, h, ratios, factors in (
        ("plate", 2.0, 0.05, (1e-3, 1e-4), (0.25, 0.5, 1.0)),
        ("obstacle", 0.292, 0.012, (1e-2, 1e-3, 1e-4), (0.0, 0.25, 0.5, 1.0)),
    ):
        for r in ratios:
            rho = r * RHO_W * H / h
            for c in factors:
                sets = [f"structure.members.0.material.density={rho!r}"]
                if c > 0.0:
                    sets += [
                        'structure.members.0.fictitious_mass_model="potential_flow"',
                        f"structure.members.0.fictitious_mass={c!r}",
                    ]
                out.append((f"{scene}_shaped", scene, "potential_flow_factor", c, sets, None))
    return out


def _ratio(run) -> float:
    """The mass ratio (rho_s h) / (rho_w H) a run of :func:`sweeps` sets (its density override;
    nan without one)."""
    toml, H, h, *_ = SCENES[run[1]]
    for item in run[4]:
        if item.startswith("structure.members.0.material.density="):
            return float(item.split("=", 1)[1]) * h / (RHO_W * H)
    return math.nan


def run_one(
    scene: str,
    sets: list[str],
    end: float | None,
    accel: str,
    path: Path,
    relaxation: float | None = None,
) -> dict:
    from mpsfem.scenario.loader import load_scenario
    from mpsfem.simulation import RunFailed, run_coupled

    toml, H, h, probe, comp, spacing, end0, bound = SCENES[scene]
    end = end0 if end is None else end
    base = [
        "run.threads=1",
        f"fluid.spacing={spacing}",
        "structure.members.0.self_weight=false",
        "output.snapshot_interval=0",
        "output.checkpoint_interval=0",
        "output.probe_interval=0",
        'coupling.scheme="implicit"',
        (
            f'coupling.acceleration={{kind = "{accel}"}}'
            if relaxation is None
            else f'coupling.acceleration={{kind = "{accel}", relaxation = {relaxation!r}}}'
        ),
        "coupling.convergence.relative_tolerance=0.001",
        "coupling.convergence.max_iterations=30",
        f"coupling.convergence.max_displacement={bound!r}",
    ]
    if scene in SPH_SCENES:
        base += SPH_SCENES[scene]
    else:
        base.append("fluid.surface.freeze_in_coupling_window=true")
    loaded = load_scenario(toml, base + sets)
    m = loaded.scenario.structure.members[0]
    ratio = m.material.density * h / (RHO_W * H)
    verdict = "converged every window"
    tic = time.perf_counter()
    try:
        run_coupled(loaded, path, end, progress=False, log=lambda msg: None)
    except RunFailed as exc:
        cause = exc.__cause__ or exc
        verdict = f"stopped: {type(cause).__name__}: {str(cause)[:160]}"
    wall = time.perf_counter() - tic
    with h5py.File(path, "r") as h5:
        it = h5["coupling/iterations"][:] if "coupling" in h5 else np.zeros(0)
        conv = h5["coupling/converged"][:] if "coupling" in h5 else np.zeros(0)
        fe = (
            h5["coupling/fictitious_force_error"][:]
            if "coupling/fictitious_force_error" in h5
            else np.zeros(0)
        )
        w = h5[f"probes/{probe}/value"][:, comp] if f"probes/{probe}" in h5 else np.zeros(0)
        tw = h5[f"probes/{probe}/time"][:] if f"probes/{probe}" in h5 else np.zeros(0)
    if not np.isfinite(w).all():
        verdict = f"NOT FINITE displacement ({verdict})"
    elif verdict.startswith("converged") and (conv == 0).any():
        verdict = f"ran to the end, {int((conv == 0).sum())} windows not converged"
    peak_t = math.nan
    if w.size and scene.startswith("plate"):
        disp = float(w[tw >= 0.5 * tw[-1]].mean())
    elif w.size:
        disp = float(w[np.argmax(np.abs(w))])
        peak_t = float(tw[np.argmax(np.abs(w))])
    else:
        disp = math.nan
    wet = np.isfinite(fe) if fe.size == it.size else np.zeros(it.size, dtype=bool)
    fe = fe[np.isfinite(fe)]
    return {
        "iterations_mean_wet": round(float(it[wet].mean()), 3) if wet.any() else "",
        "not_converged_wet": int((conv[wet] == 0).sum()) if wet.any() else "",
        "peak_time_s": peak_t,
        "wet_windows": int(fe.size),
        "force_error_max": float(fe.max()) if fe.size else "",
        "mass_ratio": round(ratio, 6),
        "verdict": verdict,
        "end_time_s": end,
        "windows": int(it.size),
        "iterations_mean": round(float(it.mean()), 3) if it.size else "",
        "iterations_max": int(it.max()) if it.size else "",
        "windows_not_converged": int((conv == 0).sum()),
        "displacement_m": disp,
        "wall_s": round(wall, 1),
    }


MOCK_FIELDS = ["sweep", "acceleration", "a_prev", "relative_to", "force_tolerance", "fictitious_x_added",
               "added_over_structure", "verdict", "windows", "iterations_mean", "iterations_max",
               "error_vs_reference", "wall_s"]  # fmt: skip


def mock_sweep(out: Path) -> None:
    """``--only mock_fictitious``: the FEM beam (structure_cases.BEAM, inextensible) against the
    added-mass mock at added / structure mass 1e4, 2 ms = 20 windows of 0.1 ms; fictitious mass
    0, 0.3, 1, 3 x the mock's mean added mass per m^2; unrelaxed (constant, omega 1), aitken,
    iqn-imvj; a^{k-1} shifted to the fluid's iterate (the coupler's set_iterate hook) or the
    structure's own (hook hidden); rtol 1e-3 relative to the displacement and to the window's
    motion, absolute tolerance 1e-22 m; coupling.convergence.fictitious_force_tolerance "off"
    (the rows before the criterion, reproduced), 1e-2 and 1e-3. Error: max |d - d_ref| / max
    |d_ref| at the end, d_ref from iqn-imvj without fictitious mass at rtol 1e-12 of the
    window's motion."""
    import copy
    import warnings

    sys.path.insert(0, str(ROOT / "tests" / "structure_fem"))
    import structure_cases

    from mpsfem.coupler import mock
    from mpsfem.coupler.coupling_scheme import create_scheme
    from mpsfem.coupler.errors import CouplingError
    from mpsfem.scenario.coupling import CouplingSection
    from mpsfem.structure_fem.participant import StructureParticipant

    mu, rho_h = 1e4, 1100.0 * 0.04
    m_a = mu * rho_h

    def run(mf, acc, rel, rtol=1e-3, hook=True, max_it=30, ftol="off"):
        beam = copy.deepcopy(structure_cases.BEAM)
        beam.update(axial=False, fictitious_mass=mf)
        st = StructureParticipant(structure_cases.section([beam]))
        if not hook:
            st.set_iterate = None  # the coupler finds no hook: a^{k-1} is the structure's own
        fluid = mock.AddedMassFluid(
            st, mass_ratio=mu, spacing=0.005, pressure=200.0, dt=4e-5, structure_mass=rho_h * 0.25
        )
        conv = {"relative_tolerance": rtol, "absolute_tolerance": 1e-22, "relative_to": rel,
                "max_iterations": max_it, "fictitious_force_tolerance": ftol}  # fmt: skip
        cfg = CouplingSection.model_validate(
            {"mapping": {"kind": "shape-function"}, "acceleration": acc, "convergence": conv}
        )
        sch = create_scheme(fluid, st, cfg)
        tic = time.perf_counter()
        verdict = "converged every window"
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            try:
                sch.run(2e-3)
            except CouplingError as exc:
                verdict = f"stopped: {type(exc).__name__}: {str(exc)[:90]}"
        h = sch.history_arrays()
        return verdict, h, st.read("displacement")[:, 0], time.perf_counter() - tic

    _, _, ref, _ = run(0.0, {"kind": "iqn-imvj"}, "window_motion", rtol=1e-12, max_it=200)
    accs = {"constant (omega 1)": {"kind": "constant", "relaxation": 1.0},
            "aitken": {"kind": "aitken"}, "iqn-imvj": {"kind": "iqn-imvj"}}  # fmt: skip
    with out.open("w", newline="") as fh:
        wr = csv.DictWriter(fh, fieldnames=MOCK_FIELDS)
        wr.writeheader()
        for ftol, rel, name, hook, f in itertools.product(
            ("off", 1e-2, 1e-3),
            ("displacement", "window_motion"),
            accs,
            (True, False),
            (0.0, 0.3, 1.0, 3.0),
        ):
            if (f == 0.0 and not hook) or (f == 0.0 and ftol != "off"):
                continue  # no hook without M_f; the criterion acts only with M_f
            acc = accs[name]
            verdict, h, d, wall = run(f * m_a, acc, rel, hook=hook, ftol=ftol)
            it = h["iterations"]
            done = verdict.startswith("converged") and np.isfinite(d).all()
            err = float(np.abs(d - ref).max() / np.abs(ref).max()) if done else ""
            row = {"sweep": "mock_fictitious", "acceleration": name,
                   "a_prev": "iterate" if hook else "own",
                   "relative_to": rel, "force_tolerance": ftol,
                   "fictitious_x_added": f,
                   "added_over_structure": mu, "verdict": verdict,
                   "windows": int(it.size),
                   "iterations_mean": round(float(it.mean()), 2) if it.size else "",
                   "iterations_max": int(it.max()) if it.size else "",
                   "error_vs_reference": err, "wall_s": round(wall, 2)}  # fmt: skip
            wr.writerow(row)
            fh.flush()
            print(row, flush=True)
    print(f"wrote {out}")


def window_operator(forces, x0, s0, F0, nodes, nrm, T, eps=1e-7, beta=0.25, gamma=0.5):
    """The added-mass matrix (kg/m per node) the fluid window presents on ``nodes``, one node
    moved at a time by eps (m) along its normal ``nrm`` from the first iterate (x0, s0) whose
    forces are F0 (the window-end velocity moved by gamma eps / (beta T)): column j is -dF_n /
    delta_a, delta_a = gamma eps / (beta T^2) the change of the window's mean wall acceleration
    (the map is linear there: the shapes' rows). Returns it and its relative asymmetry."""
    Mw = np.zeros((nodes.size, nodes.size))
    for j, node in enumerate(nodes):
        x, sv = x0.copy(), s0.copy()
        x[node] += eps * nrm[node]
        sv[node] += (gamma / (beta * T)) * eps * nrm[node]
        dFn = np.einsum("ij,ij->i", forces(x, sv) - F0, nrm)
        Mw[:, j] = -dFn[nodes] / (gamma * eps / (beta * T * T))
    return Mw, float(np.abs(Mw - Mw.T).max() / np.abs(Mw).max())


def plate_map_probe(
    out: Path,
    ratio: float = 1e-3,
    windows: int = 25,
    spacing: float | None = None,
    scene: str = "plate",
) -> None:
    """``--only plate_map`` (task H1): the added mass the MPS window presents to the
    hydrostatic plate along a few interface shapes, against the two potential-flow operators.

    The plate of ``plate_shaped`` (l0 0.05 m, window 0.2 ms, mass ratio ``ratio``, Aitken, no
    fictitious mass) is stepped ``windows`` windows from rest in process; then, from that
    window's start, the fluid window is evaluated as a map x -> F at the first iterate x0 and at
    x0 + eps w (the window-end velocity moved consistently by gamma eps w / (beta T)), giving

        m_w = -(w . (F(x0 + eps w) - F(x0))) / (|w|^2 delta_a),  delta_a = gamma eps / (beta T^2)

    (delta_a: the change of the window's mean wall acceleration, what the fluid sees; beta 1/4,
    gamma 1/2; the method of validation/bottom_slamming_light_iterations.py), against w M w /
    |w|^2 of the impact operator (added_mass_potential) and of the tank-bottom operator
    (added_mass_tank, H = 2 m) on the same nodes. Shapes: rigid heave, the clamped first mode
    sin^2(pi x / L), the tank's cos(pi x / L) and cos(2 pi x / L) (no volume change).

    ``scene = "obstacle"`` (``--only obstacle_map``): the obstacle at ``ratio`` stepped
    ``windows`` windows (into the surge's contact), the shapes and the matrix on the run of
    nodes whose first-iterate pressure exceeds 1 Pa (the clamped foot excluded), against the
    impact operator of that run only (the tank operator does not apply)."""
    from mpsfem.coupler.coupling_scheme import create_scheme
    from mpsfem.fluid_methods import create_fluid_participant
    from mpsfem.scenario.loader import load_scenario
    from mpsfem.simulation import coupling_config, member_nodes
    from mpsfem.structure_fem.added_mass_potential import patch_added_mass, patch_coordinates
    from mpsfem.structure_fem.added_mass_tank import tank_bottom_added_mass
    from mpsfem.structure_fem.participant import StructureParticipant

    toml, H, h, *_, l0, _end, bound = SCENES[scene]
    spacing = l0 if spacing is None else spacing  # fluid.spacing (m)
    sets = [
        "run.threads=1",
        f"fluid.spacing={spacing}",
        "structure.members.0.self_weight=false",
        'coupling.scheme="implicit"',
        'coupling.acceleration={kind = "aitken"}',
        "coupling.convergence.relative_tolerance=0.001",
        "coupling.convergence.max_iterations=30",
        "fluid.surface.freeze_in_coupling_window=true",
        f"coupling.convergence.max_displacement={bound!r}",
        f"structure.members.0.material.density={ratio * RHO_W * H / h!r}",
    ]
    loaded = load_scenario(toml, sets)
    sc = loaded.scenario
    st = StructureParticipant(
        sc.structure, base_dir=loaded.path.parent, fluid_density=sc.fluid.density
    )
    mesh = st.interface()
    fluid = create_fluid_participant(
        sc.fluid, mesh, base_dir=loaded.path.parent, member_names=[m for m, _ in member_nodes(sc)]
    )
    scheme = create_scheme(fluid, st, coupling_config(sc, None), log=lambda m: None)
    scheme.initialize()
    for _ in range(windows):
        scheme.advance_window()
    T = scheme.window
    t0, t1 = scheme.t, scheme.t + T
    d_f0 = scheme.mapping.displacement_to_fluid(scheme.d)
    v_f0 = scheme.mapping.velocity_to_fluid(scheme.v, scheme.d)
    x0, s0 = scheme.d + T * scheme.v, scheme.v.copy()  # the window's first iterate
    fluid.checkpoint()

    def forces(x, s):
        fluid.restore()
        F, _ = scheme._fluid_window(
            t0, t1, d_f0, v_f0,
            scheme.mapping.displacement_to_fluid(x), scheme.mapping.velocity_to_fluid(s, x),
        )  # fmt: skip
        return scheme.mapping.forces_to_structure(F, x)

    F0 = forces(x0, s0)
    repeat = float(np.abs(forces(x0, s0) - F0).max())
    pts = np.asarray(mesh.points)
    nrm = np.asarray(mesh.normals)
    if scene == "obstacle":
        return _obstacle_map(out, ratio, scheme, fluid, forces, x0, s0, F0, repeat, pts, nrm, sc)
    xs = patch_coordinates(pts)
    L = xs[-1]
    ops = {
        "impact": patch_added_mass(xs, sc.fluid.density),
        "tank": tank_bottom_added_mass(xs, sc.fluid.density, H),
    }
    shapes = {
        "heave": np.ones(xs.size),
        "sin2": np.sin(np.pi * xs / L) ** 2,
        "cos1": np.cos(np.pi * xs / L),
        "cos2": np.cos(2.0 * np.pi * xs / L),
        "cos5": np.cos(5.0 * np.pi * xs / L),
        "zigzag": (-1.0) ** np.arange(xs.size),
    }
    beta, gamma = 0.25, 0.5
    rows = []
    for name, w in shapes.items():
        ref = {k: float(w @ M @ w / (w @ w)) for k, M in ops.items()}
        for eps in (1e-8, 1e-7, 1e-6):
            x = x0 + eps * w[:, None] * nrm
            s = s0 + (gamma / (beta * T)) * eps * w[:, None] * nrm
            dFn = np.einsum("ij,ij->i", forces(x, s) - F0, nrm)
            m = -float(w @ dFn) / (float(w @ w) * gamma * eps / (beta * T * T))
            row = {"t_start_s": t0, "mass_ratio": ratio, "shape": name, "eps_m": eps,
                   "m_w_kg_per_m": m, "impact_kg_per_m": ref["impact"],
                   "tank_kg_per_m": ref["tank"], "m_w_over_impact": m / ref["impact"],
                   "m_w_over_tank": m / ref["tank"], "repeat_diff_N_per_m": repeat}  # fmt: skip
            rows.append(row)
            print(row, flush=True)
    # the whole window operator on the free (interior) nodes, one node at a time (eps 1e-7 m:
    # the map is linear there, the rows above), and its generalized eigenvalues lambda against
    # each operator: M_mps v = lambda M_op v. Under M_f = c M_op an unrelaxed iteration
    # multiplies a mode's error by about 1 - gamma lambda / c (m_s << m_a; the fluid answers
    # to the window's mean acceleration, gamma of the end acceleration's change), so it
    # contracts for c > gamma lambda / 2 and best at c = gamma lambda
    free = np.arange(1, xs.size - 1)
    Mw, asym = window_operator(forces, x0, s0, F0, free, nrm, T)
    fluid.restore()
    Ms = 0.5 * (Mw + Mw.T)
    modes = []
    lam = {
        k: np.sort(sla.eigh(Ms, M[np.ix_(free, free)], eigvals_only=True)) for k, M in ops.items()
    }
    for k in range(free.size):
        modes.append({"mass_ratio": ratio, "t_start_s": t0, "mode": k,
                      "lambda_vs_impact": lam["impact"][k], "lambda_vs_tank": lam["tank"][k],
                      "asymmetry_rel": asym})  # fmt: skip
    print(f"MPS window operator: asymmetry {asym:.3g}; lambda vs impact "
          f"{lam['impact'].min():.3g}..{lam['impact'].max():.3g}, vs tank "
          f"{lam['tank'].min():.3g}..{lam['tank'].max():.3g}")  # fmt: skip
    out.parent.mkdir(parents=True, exist_ok=True)
    for path, table in ((out, rows), (out.with_name(out.stem + "_modes.csv"), modes)):
        with path.open("w", newline="") as fh:
            wr = csv.DictWriter(fh, fieldnames=list(table[0]))
            wr.writeheader()
            wr.writerows(table)
        print(f"wrote {path}")


def _obstacle_map(out, ratio, scheme, fluid, forces, x0, s0, F0, repeat, pts, nrm, sc) -> None:
    """:func:`plate_map_probe` on the obstacle's wetted run (``--only obstacle_map``)."""
    from mpsfem.structure_fem.added_mass_potential import patch_added_mass, patch_coordinates
    from mpsfem.structure_fem.fictitious_mass import node_runs, tributary_measure

    T, t0 = scheme.window, scheme.t
    beta, gamma = 0.25, 0.5
    cells = np.c_[np.arange(pts.shape[0] - 1), np.arange(1, pts.shape[0])]
    pressure = np.einsum("ij,ij->i", F0, nrm) / tributary_measure(pts, cells)
    runs = node_runs(pts, np.abs(pressure) > 1.0)
    if not runs:
        raise SystemExit(f"obstacle_map: no node above 1 Pa at t = {t0:.4f} s")
    run = max(runs, key=len)
    run = run[run != 0]  # node 0: the clamped foot
    xs = patch_coordinates(pts[run])
    L = xs[-1]
    Ma = patch_added_mass(xs, sc.fluid.density)
    shapes = {
        "heave": np.ones(xs.size),
        "sin_half": np.sin(np.pi * xs / L),
        "sin_full": np.sin(2.0 * np.pi * xs / L),
        "zigzag": (-1.0) ** np.arange(xs.size),
    }
    print(f"t = {t0:.4f} s: wet run nodes {run.min()}-{run.max()} ({L * 1e3:.1f} mm), "
          f"pressure {np.abs(pressure[run]).min():.3g}-{np.abs(pressure[run]).max():.3g} Pa")  # fmt: skip
    rows = []
    for name, w in shapes.items():
        ref = float(w @ Ma @ w / (w @ w))
        for eps in (1e-8, 1e-7, 1e-6):
            x, sv = x0.copy(), s0.copy()
            x[run] += eps * w[:, None] * nrm[run]
            sv[run] += (gamma / (beta * T)) * eps * w[:, None] * nrm[run]
            dFn = np.einsum("ij,ij->i", (forces(x, sv) - F0)[run], nrm[run])
            m = -float(w @ dFn) / (float(w @ w) * gamma * eps / (beta * T * T))
            row = {"t_start_s": t0, "mass_ratio": ratio, "shape": name, "eps_m": eps,
                   "wet_run_nodes": int(run.size), "wet_run_length_m": float(L),
                   "m_w_kg_per_m": m, "impact_kg_per_m": ref, "m_w_over_impact": m / ref,
                   "repeat_diff_N_per_m": repeat}  # fmt: skip
            rows.append(row)
            print(row, flush=True)
    Mw, asym = window_operator(forces, x0, s0, F0, run, nrm, T)
    fluid.restore()
    lam = np.sort(sla.eigh(0.5 * (Mw + Mw.T), Ma, eigvals_only=True))
    modes = [{"mass_ratio": ratio, "t_start_s": t0, "mode": k, "lambda_vs_impact": lam[k],
              "asymmetry_rel": asym} for k in range(run.size)]  # fmt: skip
    print(f"MPS window operator: asymmetry {asym:.3g}; lambda vs impact "
          f"{lam.min():.3g}..{lam.max():.3g}")  # fmt: skip
    out.parent.mkdir(parents=True, exist_ok=True)
    for path, table in ((out, rows), (out.with_name(out.stem + "_modes.csv"), modes)):
        with path.open("w", newline="") as fh:
            wr = csv.DictWriter(fh, fieldnames=list(table[0]))
            wr.writeheader()
            wr.writerows(table)
        print(f"wrote {path}")


def _probe_tank_operator(depth: float) -> None:
    """A probe, not a scenario setting (task H1): the ``potential_flow`` model's operator is
    replaced in this process by the tank-bottom one (:func:`~mpsfem.structure_fem.
    added_mass_tank.tank_bottom_added_mass`: rigid walls at the wetted run's ends, water depth
    ``depth`` m, phi = 0 on the free surface), to measure whether the impact operator's
    geometry (free surface continuing the patch's line, infinite depth) matters on the
    hydrostatic plate, a tank's whole bottom under a 2 m column."""
    from mpsfem.structure_fem import fictitious_mass
    from mpsfem.structure_fem.added_mass_tank import tank_bottom_added_mass

    def operator(s, density):
        return tank_bottom_added_mass(s, density, depth)

    fictitious_mass.patch_added_mass = operator


def _install_trace(path: Path, t_from: float) -> None:
    """A probe, not a scenario setting (task H2): trace every iteration of the coupling windows
    starting at or after ``t_from`` s into ``path`` (JSON lines, one per iteration): the window
    index and start, the normal nodal load on the structure (N/m, positive pushing along +x, the
    obstacle's downstream side), the interface iterate x and the structure's answer x~ (x
    components, m), the fictitious mass's wet nodes, the force-error triple (e, S, A) of
    ``fictitious_force_error``, Aitken's relaxation factor, and the residual-norm history of
    every Newton solve of the structure's window; and the scheme's warnings. Monkeypatches
    the coupler and structure in this process (:func:`summarize_trace` reads the file)."""
    import json

    from mpsfem.coupler import coupling_scheme as cs
    from mpsfem.structure_fem import alpha_method as am
    from mpsfem.structure_fem import participant as sp

    log = path.open("w")
    state: dict = {"solves": [], "x": None}
    newton_solve = am.newton_solve

    def traced_newton(residual, jacobian, x0, **kw):
        hist: list[float] = []

        def res(x):
            r, scale, floor = residual(x)
            hist.append(float(np.sqrt(r @ r)))
            return r, scale, floor

        state["solves"].append(hist)
        return newton_solve(res, jacobian, x0, **kw)

    am.newton_solve = traced_newton
    structure_window = cs.CouplingScheme._structure_window

    def traced_window(self, t0, t1, F1):
        state["solves"] = []
        out = None
        try:
            out = structure_window(self, t0, t1, F1)
            return out
        finally:
            if t0 >= t_from:
                st = self.structure
                fe = st.fictitious_force_error() if st.fictitious is not None else None
                rec = {
                    "index": self.index,
                    "t0": t0,
                    "F_normal": (-F1[:, 0]).round(4).tolist(),
                    "x_dx": state["x"][:, 0].round(8).tolist(),
                    "xt_dx": None if out is None else out[0][:, 0].round(8).tolist(),
                    "wet": np.flatnonzero(st.fictitious_nodes).tolist()
                    if st.fictitious is not None
                    else [],
                    "force_err": None if fe is None else [float(v) for v in fe],
                    "omega": getattr(self.acceleration, "omega", None),
                    "newton": [[round(v, 4) for v in h] for h in state["solves"]],
                }
                log.write(json.dumps(rec) + "\n")
                log.flush()

    cs.CouplingScheme._structure_window = traced_window
    set_iterate = sp.StructureParticipant.set_iterate

    def traced_iterate(self, x, window):
        state["x"] = np.array(x)
        return set_iterate(self, x, window)

    sp.StructureParticipant.set_iterate = traced_iterate
    warn = cs.CouplingScheme._warn

    def traced_warn(self, msg):
        if self.t >= t_from:
            log.write(json.dumps({"warn": msg[:400]}) + "\n")
            log.flush()
        return warn(self, msg)

    cs.CouplingScheme._warn = traced_warn  # a failing solve's history: the record's last


def summarize_trace(path: Path) -> dict:
    """Counts over a :func:`_install_trace` file (task H2): windows traced, not converged (30
    iterations), and of those not converged: "dry_stall" (every iterate's load below 1 N/m
    while M_f acts: the fictitious mass alone holds the member), "redecided_dry" (a wet iterate
    met both criteria, then the load fell below 0.01 N/m in every later iterate: the fluid's
    flags re-decided at convergence leave the wall dry), "flip" (iterates alternate between a
    dry load, below 1 N/m, and a wet one, above 100 N/m, in the last ten: a jump of the fluid's
    map), and "slow" (the rest). Approximate: S_peak is the largest S of the traced windows."""
    import json
    from collections import defaultdict

    wins = defaultdict(list)
    for line in path.open():
        r = json.loads(line)
        if "x_dx" in r and r.get("xt_dx") is not None:
            wins[r["index"]].append(r)
    out = {"windows": 0, "not_converged": 0, "dry_stall": 0, "redecided_dry": 0, "flip": 0,
           "slow": 0, "iterations": 0, "force_limited": 0}  # fmt: skip
    accepted = []  # (load, tip dx) of each window's last traced iteration (the accepted one)
    s_peak = 0.0
    for _, its in sorted(wins.items()):
        out["windows"] += 1
        out["iterations"] += len(its)
        load = [abs(sum(r["F_normal"])) for r in its]
        rel = []
        ok = []
        for r in its:
            x, xt = np.array(r["x_dx"]), np.array(r["xt_dx"])
            rel.append(float(np.sqrt(np.mean((xt - x) ** 2)) / max(np.sqrt(np.mean(xt**2)), 1e-30)))
            fe = r["force_err"]
            f_ok = fe is None or fe[0] <= max(1e-2 * max(fe[1], s_peak), fe[2])
            ok.append(rel[-1] <= 1e-3 and f_ok)
        if its[-1]["force_err"] is not None:
            s_peak = max(s_peak, its[-1]["force_err"][1])
        accepted.append((load[-1], its[-1]["xt_dx"][-1]))
        if len(its) < 30:
            continue
        out["not_converged"] += 1
        # the displacement residual met in one of the last ten iterates: the force error limits
        out["force_limited"] += int(min(rel[-10:]) <= 1e-3)
        k0 = next((k for k in range(len(its)) if ok[k] and load[k] > 1.0), None)
        tail = load[-10:]
        if its[0]["wet"] and max(load) < 1.0:
            out["dry_stall"] += 1
        elif k0 is not None and all(v < 0.01 for v in load[k0 + 1 :]):
            out["redecided_dry"] += 1
        elif min(tail) < 1.0 and max(tail) > 100.0:
            out["flip"] += 1
        else:
            out["slow"] += 1
    # contact events: accepted windows switching between wet (load > 1 N/m) and dry (< 0.1);
    # the tip's local maxima above 2 mm and their spacing in windows (the member's bounces)
    load = np.array([a[0] for a in accepted])
    tip = np.array([a[1] for a in accepted])
    wet, dry = load > 1.0, load < 0.1
    out["wet_dry_switches"] = int(np.sum(wet[1:] & dry[:-1]) + np.sum(dry[1:] & wet[:-1]))
    d = np.diff(tip)
    peaks = [k for k in range(1, d.size) if d[k - 1] > 0 >= d[k] and tip[k] > 2e-3]
    out["tip_peaks"] = len(peaks)
    out["tip_peak_spacing_median"] = float(np.median(np.diff(peaks))) if len(peaks) > 1 else ""
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--only", default=None, help="comma-separated sweeps (default: the first four)")
    ap.add_argument("--values", default=None, help="comma-separated factor values to keep")
    ap.add_argument("--ratios", default=None, help="comma-separated mass ratios to keep")
    ap.add_argument("--acceleration", default="iqn-imvj")
    ap.add_argument(
        "--relaxation", type=float, default=None, help='omega of --acceleration "constant"'
    )
    ap.add_argument("--out", type=Path, default=ROOT / "benchmarks/results/coupling_stress.csv")
    ap.add_argument("--append", action="store_true", help="add rows to an existing CSV")
    ap.add_argument(
        "--set", action="append", default=[], help="extra scenario override for every run"
    )
    ap.add_argument(
        "--wet-pressure",
        type=float,
        default=None,
        help="structure.members.0.fictitious_wet_pressure (Pa) for every run",
    )
    ap.add_argument(
        "--force-tolerance",
        type=float,
        default=None,
        help="coupling.convergence.fictitious_force_tolerance for every run (default 1e-2)",
    )
    ap.add_argument(
        "--probe-tank-depth",
        type=float,
        default=None,
        help="a probe (task H1): the potential_flow model's operator replaced in-process by the "
        "tank-bottom one (structure_fem/added_mass_tank.py) at this water depth (m)",
    )
    ap.add_argument(
        "--keep-h5",
        type=Path,
        default=None,
        help="keep each run's results file in this folder (default: a temporary one)",
    )
    ap.add_argument(
        "--map-spacing",
        type=float,
        default=None,
        help="plate_map: fluid.spacing (m; default the sweeps' 0.05), its own CSV",
    )
    ap.add_argument(
        "--map-windows",
        type=int,
        default=560,
        help="obstacle_map: windows stepped before the probe (default 560: t = 0.14 s)",
    )
    ap.add_argument(
        "--trace",
        type=Path,
        default=None,
        help="a probe (task H2): trace every coupling iteration from --trace-from s on into "
        "this JSON-lines file (one run: use with --values / --ratios selecting one), and print "
        "its summary",
    )
    ap.add_argument(
        "--end-time",
        type=float,
        default=None,
        help="end time (s) of every run (default: the scene's)",
    )
    ap.add_argument("--trace-from", type=float, default=0.118, help="--trace start (s)")
    ap.add_argument(
        "--summarize-trace", type=Path, default=None, help="print the summary of a --trace file"
    )
    args = ap.parse_args(argv)
    if args.summarize_trace is not None:
        got = summarize_trace(args.summarize_trace)
        print(got)
        if args.out != ROOT / "benchmarks/results/coupling_stress.csv":  # a row per trace
            row = {"trace": args.summarize_trace.name, "settings": " ".join(args.set)} | got
            new = not (args.append and args.out.exists())
            with args.out.open("w" if new else "a", newline="") as fh:
                wr = csv.DictWriter(fh, fieldnames=list(row))
                if new:
                    wr.writeheader()
                wr.writerow(row)
            print(f"wrote {args.out}")
        return 0
    if args.trace is not None:
        _install_trace(args.trace, args.trace_from)
    if args.probe_tank_depth is not None:
        _probe_tank_operator(args.probe_tank_depth)
    if args.only == "obstacle_map":
        plate_map_probe(
            ROOT / "benchmarks/results/coupling_stress_shaped_obstacle_map.csv",
            ratio=0.103,
            windows=args.map_windows,
            scene="obstacle",
        )
        return 0
    if args.only == "plate_map":
        name = "coupling_stress_shaped_plate_map"
        if args.map_spacing is not None:
            name += f"_l0_{args.map_spacing:g}"
        plate_map_probe(ROOT / f"benchmarks/results/{name}.csv", spacing=args.map_spacing)
        return 0
    if args.only == "mock_fictitious":
        default = ROOT / "benchmarks/results/coupling_stress.csv"
        mock_sweep(
            ROOT / "benchmarks/results/coupling_stress_mock_fictitious.csv"
            if args.out == default
            else args.out
        )
        return 0
    runs = sweeps()
    if not args.only:
        runs = [
            r for r in runs if not (r[0].endswith(("_fictitious", "_shaped")) or "_sph_" in r[0])
        ]
    if args.only:
        keep = set(args.only.split(","))
        unknown = keep - {r[0] for r in runs}
        if unknown:
            ap.error(f"--only {args.only!r}: unknown {sorted(unknown)}")
        runs = [r for r in runs if r[0] in keep]
    if args.values:
        vals = [float(v) for v in args.values.split(",")]
        runs = [r for r in runs if any(abs(r[3] - v) <= 1e-12 * abs(v) for v in vals)]
    if args.ratios:
        keep_r = [float(v) for v in args.ratios.split(",")]
        runs = [r for r in runs if any(abs(_ratio(r) - v) <= 1e-9 * v for v in keep_r)]
    fields = ["sweep", "scene", "acceleration", "factor", "value", "mass_ratio", "verdict",
              "end_time_s", "windows", "iterations_mean", "iterations_max",
              "windows_not_converged", "displacement_m", "wall_s"]  # fmt: skip
    fictitious_only = all(r[0].endswith(("_fictitious", "_shaped")) for r in runs)
    shaped_only = all(r[0].endswith("_shaped") for r in runs)
    sph_only = all("_sph_" in r[0] for r in runs)
    if fictitious_only:  # the fictitious-mass runs' extra columns (issue 21)
        fields += ["peak_time_s", "wet_windows", "force_error_max", "settings"]
    elif sph_only:  # the δ-SPH runs: the spacing and the coupling's safeguards
        fields += ["peak_time_s", "settings"]
    elif args.set:  # any other run with overrides names them
        fields += ["settings"]
    if shaped_only:  # task H1: the iterations of the windows in which M_f acted
        fields += ["iterations_mean_wet", "not_converged_wet"]
        if args.out == ROOT / "benchmarks/results/coupling_stress.csv":
            args.out = ROOT / "benchmarks/results/coupling_stress_shaped.csv"
    if args.wet_pressure is not None:
        args.set = args.set + [f"structure.members.0.fictitious_wet_pressure={args.wet_pressure!r}"]
    if args.force_tolerance is not None:
        args.set = args.set + [
            f"coupling.convergence.fictitious_force_tolerance={args.force_tolerance!r}"
        ]
    args.out.parent.mkdir(parents=True, exist_ok=True)
    new = not (args.append and args.out.exists())
    if not new:
        with args.out.open() as fh:
            have = fh.readline().strip().split(",")
        if have != fields:
            ap.error(f"--append {args.out}: its columns {have} are not these runs' {fields}")
    with args.out.open("w" if new else "a", newline="") as fh, tempfile.TemporaryDirectory() as tmp:
        wr = csv.DictWriter(fh, fieldnames=fields)
        if new:
            wr.writeheader()
        accel_name = args.acceleration + (
            "" if args.relaxation is None else f" (omega {args.relaxation:g})"
        )
        for k, (sweep, scene, factor, value, sets, end) in enumerate(runs):
            row = {"sweep": sweep, "scene": scene, "acceleration": accel_name,
                   "factor": factor, "value": value}  # fmt: skip
            path = Path(tmp) / f"r{k}.h5"
            if args.keep_h5 is not None:
                args.keep_h5.mkdir(parents=True, exist_ok=True)
                stamp = f"{time.strftime('%H%M%S')}_{os.getpid()}"  # two runs in one second
                path = (
                    args.keep_h5
                    / f"{sweep}_{value:g}_{_ratio((sweep, scene, factor, value, sets)):g}_{stamp}.h5"
                )
            sets = sets + args.set
            end = args.end_time if args.end_time is not None else end
            got = run_one(scene, sets, end, args.acceleration, path, args.relaxation)
            if "settings" in fields:
                got["settings"] = " ".join(args.set)
                if args.probe_tank_depth is not None:
                    got["settings"] += f" probe:tank_bottom_operator_depth={args.probe_tank_depth}"
            row.update({k: v for k, v in got.items() if k in fields})
            wr.writerow(row)
            fh.flush()
            print(row, flush=True)
    print(f"wrote {args.out}")
    if args.trace is not None:
        print(f"trace {args.trace}: {summarize_trace(args.trace)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
