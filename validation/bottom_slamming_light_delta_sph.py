"""The thesis's light bottom-slamming plate under the δ-SPH fluid (issue 21, task H7).

validation/bottom_slamming_light.py runs the light plate (0.026 kg/m^2, Aitken, the fictitious
mass M_f on wetted nodes, the force-error criterion) with the MPS fluid; after first contact
most of its wet windows stay unconverged. This script asks whether they converge under the
quieter δ-SPH fluid (docs/fluid_sph.md), and whether the answer depends on M_f.

The δ-SPH scenarios are scenarios/bottom_slamming_2d.toml (rigid) and
scenarios/bottom_slamming_elastic_2d.toml (elastic) with fluid.method = "delta-sph", MPS's
numerical tables dropped ([fluid.pressure], fluid.time_step.courant), the default [fluid.sph]
except fluid.sph.damping = "sponge" (the scenarios' sponge, MPS's velocity damping with the
same coefficient, instead of the seed's viscosity ramp, which would limit dt to 0.15 h /
(0.6 c0) over the whole tank): written to validation/results/bottom_slamming_dsph_<kind>.toml.
Every case override is validation/bottom_slamming.py's :func:`case_overrides`, the light
section, M_f and Aitken validation/bottom_slamming_light.py's :func:`light_overrides`, and
every measurement that script's :func:`analyse_light` (bottom_slamming.py's :func:`analyse`),
with MF against the δ-SPH rigid plate of the same spacing and the iteration counts split at
first contact. Runs (``--runs``): ``rigid`` (force probe: the first layer's pressure
integral), ``rigid_x`` (its pair exchange, fluid.boundary_force = "momentum_exchange": the
measure the member's load is; MF divides by it); ``mf0.3``, ``mf1`` (the light plate); ``heavy``
(the scenario's own section, 15.6 kg/m^2, Aitken, no M_f); ``imvj...`` (IQN-IMVJ without M_f,
IMVJ_RUNS); ``ait_corot_sg...`` (Aitken with the MPS MF table's shaped M_f and the safeguards;
tagged, a floor under Aitken's factor or a shorter fluid step; AITKEN_RUNS). The case is A/H =
0.3 and D/H = 0.06 unless ``--amplitude`` / ``--clearance`` say otherwise (the MF table's A/H
0.2-0.5; the iteration counts of the wet windows start at :func:`wet_from`). Writes
validation/results/bottom_slamming_light_delta_sph.csv.

    NUMBA_NUM_THREADS=1 python validation/bottom_slamming_light_delta_sph.py --runs rigid
    NUMBA_NUM_THREADS=1 python validation/bottom_slamming_light_delta_sph.py --runs mf0.3
    NUMBA_NUM_THREADS=1 python validation/bottom_slamming_light_delta_sph.py \
        --runs ait_corot_sg --end-time 2.73
    NUMBA_NUM_THREADS=1 python validation/bottom_slamming_light_delta_sph.py --amplitude 0.5 \
        --clearance 0.1 --runs rigid_xw,ait_corot_sg_floor20 --end-time 2.5
    python validation/bottom_slamming_light_delta_sph.py --analyse-only
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import h5py
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import case_runner  # noqa: E402
from bottom_slamming import (  # noqa: E402
    DEPTH,
    RESULTS_DIR,
    SCENARIOS,
    Case,
    analyse,
    case_overrides,
    smooth_force,
    spacing_for,
)
from bottom_slamming_light import (  # noqa: E402
    ADDED_MASS_ESTIMATE,
    analyse_light,
    light_overrides,
)
from results_csv import read_csv, write_csv  # noqa: E402

CSV = RESULTS_DIR / "bottom_slamming_light_delta_sph.csv"
CASE = Case(0.3, 0.06)
L0 = "0.0057"  # H / 20
#: the IQN-IMVJ runs without M_f: "imvj" plus any of the tags "_corot" (co-rotational
#: kinematics), "_sg" (the safeguards of light_overrides), "_rate" (coupling.interface_velocity
#: = "displacement_rate"), "_c2" / "_c075" (2 / 0.75 times the default sound speed), "_w05"
#: (coupling window and structure step 0.5 ms instead of 1 ms), "_ga0" (the structure's HHT of
#: the safeguards replaced by generalised-alpha with rho_inf = 0), "_fend" (coupling.force_sampling
#: = "end": the fluid's force at the window's end instead of its window mean), "_shift"
#: (fluid.sph.shifting = "delta_plus"), in this order
IMVJ_RUNS = (
    "imvj",
    "imvj_sg",
    "imvj_corot",
    "imvj_corot_sg",
    "imvj_corot_sg_rate",
    "imvj_corot_sg_c2",
    "imvj_corot_sg_rate_c075",
    "imvj_corot_sg_rate_w05",
    "imvj_corot_sg_rate_ga0",
    "imvj_corot_sg_rate_fend",
    "imvj_corot_sg_rate_shift",
)
#: the Aitken runs with the MPS runs' shaped fictitious mass (issue 21, 2026-11-28): "ait_corot_sg"
#: (co-rotational member, the safeguards, potential-flow M_f factor 0.35 on nodes loaded above
#: 3 Pa, force tolerance 5e-2, at most 100 iterations: the MPS MF table's setting) plus any of
#: "_floor20" / "_floor15" (a floor under Aitken's factor, coupling.acceleration.relaxation_bounds
#: = [0.05, 20] / [0.05, 1.5]: what converged the δ-SPH obstacle at mass ratio 1e-4, L/20) and
#: "_ft01" (the force tolerance 1e-2, the schema's default) and "_cfl06" / "_cfl05"
#: (fluid.sph.cfl = 0.6 / 0.5 instead of RK4's 0.8: five / six fluid steps a window instead of
#: four, other realisations of the same physics; the floors and steps are PREFIX_TAGS) and
#: "_ga0" / "_fend" / "_w05" (the structure's generalised-alpha with rho_inf = 0 in place of the
#: safeguards' HHT / the fluid's force at the window's end instead of its window mean / a window
#: and structure step of 0.5 ms: against the period-two mode that stops the runs at A/H = 0.4
#: and 0.5), in this order; "_c075" / "_c2" (0.75 / 2 times the default sound speed: does the
#: coupled oscillation of 0.5-0.65 kHz that the elastic runs carry, and the rigid plate does
#: not, move with the fluid's sound speed?)
AITKEN_RUNS = (
    "ait_corot_sg",
    "ait_corot_sg_floor20",
    "ait_corot_sg_floor15",
    "ait_corot_sg_floor20_ft01",
    "ait_corot_sg_floor20_cfl06",
    "ait_corot_sg_floor20_cfl05",
    "ait_corot_sg_floor20_ga0",
    "ait_corot_sg_floor20_fend",
    "ait_corot_sg_floor20_w05",
    "ait_corot_sg_floor20_c075",
    "ait_corot_sg_floor20_w05_c2",
)
RUNS = ("rigid", "rigid_x", "mf0.3", "mf1", "heavy", "rigid_xw", *IMVJ_RUNS, *AITKEN_RUNS)
#: the default c0 of this case, 10 x 2 sqrt(g H) with H = 0.114 m (fluid.sph.sound_speed's
#: default; the "_c2" runs double it)
SOUND_SPEED = 20.0 * math.sqrt(9.81 * 0.114)
#: the run tags (IQN-IMVJ and Aitken runs alike) that go into the results file's name before
#: "bottom_slamming", in this order, and the overrides each adds (a tag with a structure scheme
#: replaces the safeguards' HHT)
PREFIX_TAGS = {
    "rate": ['coupling.interface_velocity="displacement_rate"'],
    "c2": [f"fluid.sph.sound_speed={2.0 * SOUND_SPEED!r}"],
    "c075": [f"fluid.sph.sound_speed={0.75 * SOUND_SPEED!r}"],
    "w05": ["coupling.window=0.0005", "structure.time.dt=0.0005"],
    "ga0": ['structure.time.scheme="generalized_alpha"', "structure.time.rho_inf=0.0"],
    "fend": ['coupling.force_sampling="end"'],
    "shift": ['fluid.sph.shifting="delta_plus"'],
    "floor20": ["coupling.acceleration.relaxation_bounds=[0.05, 20.0]"],
    "floor15": ["coupling.acceleration.relaxation_bounds=[0.05, 1.5]"],
    "cfl06": ["fluid.sph.cfl=0.6"],
    "cfl05": ["fluid.sph.cfl=0.5"],
}
#: the safeguards' structure-scheme overrides (light_overrides) that a scheme tag replaces
SAFEGUARD_SCHEME = ("structure.time.scheme", "structure.time.hht_alpha")
#: the runs with dry walls across the air gap (fluid.sph.wall_pressure = "wetted", task H2)
WETTED = 'fluid.sph.wall_pressure="wetted"'
#: the elastic runs, and the rigid pair exchange each one's MF divides by
MF_REFERENCE = {
    "mf0.3": "rigid_x",
    "mf1": "rigid_x",
    "heavy": "rigid_x",
    **{run: "rigid_xw" for run in (*IMVJ_RUNS, *AITKEN_RUNS)},
}
#: the rigid plate's force as its pair exchange (fluid.boundary_force = "momentum_exchange"),
#: the measure the coupled member's load is (docs/fluid_sph.md, "Coupled to a structure"); the
#: default, the first layer's pressure integral, also reads the pull of the negative wall
#: pressures across the gap (see the page)
EXCHANGE = 'fluid.boundary_force="momentum_exchange"'


def write_scenario(kind: str) -> Path:
    """The δ-SPH version of the kind's scenario (text edits of the MPS file, so its comments
    stay): fluid.method = "delta-sph", [fluid.pressure] and fluid.time_step.courant dropped,
    [fluid.sph] damping = "sponge"."""
    out = RESULTS_DIR / f"bottom_slamming_dsph_{kind}.toml"
    lines, skip = [], False
    for line in SCENARIOS[kind].read_text().splitlines():
        head = line.strip()
        if head.startswith("["):
            skip = head.split("#")[0].strip() == "[fluid.pressure]"
        if skip or head.startswith("courant"):
            continue
        if head.split("#")[0].strip() == "[fluid.time_step]":
            lines += ["[fluid.sph]", 'damping = "sponge"   # the sponge as in MPS (see header)', ""]
        lines.append(line)
        if head == "[fluid]":
            lines.append('method = "delta-sph"')
    header = (
        f"# written by validation/bottom_slamming_light_delta_sph.py: {SCENARIOS[kind].name} with\n"
        '# fluid.method = "delta-sph", [fluid.pressure] and fluid.time_step.courant dropped,\n'
        '# fluid.sph.damping = "sponge"\n'
    )
    RESULTS_DIR.mkdir(parents=True, exist_ok=True)
    out.write_text(header + "\n".join(lines) + "\n")
    return out


def run_path(run: str, end_time: float, ft: str = "0.01") -> Path:
    """Results file; the light runs' names parse with bottom_slamming_light.NAME (``ft``: the
    force tolerance, "off" for a branch's base)."""
    if run in ("rigid", "rigid_x", "rigid_xw"):
        return RESULTS_DIR / f"dsph_bottom_slamming_{run}_{L0}_end{end_time:g}_{CASE.label()}.h5"
    if run in IMVJ_RUNS:  # no M_f, IQN-IMVJ, wetted walls (the prefix keeps NAME's pattern;
        # "_corot" and "_sg" are NAME's own tags, PREFIX_TAGS go into the prefix)
        mid = "".join(f"_{t}" for t in ("corot", "sg") if t in run.split("_"))
        return RESULTS_DIR / (
            f"dsph_wetted_{prefix(run)}bottom_slamming_light_{L0}_mf0_rtol0.001_acciqn-imvj{mid}_ftoff_"
            f"end{end_time:g}_{CASE.label()}.h5"
        )
    if run in AITKEN_RUNS:  # wetted walls, the MPS MF table's keys (NAME's tokens) and a floor
        return RESULTS_DIR / (
            f"dsph_wetted_{prefix(run)}bottom_slamming_light_{L0}_mf0.35_rtol0.001it100_pf_wp3_corot_sg_"
            f"ft{aitken_force_tolerance(run)}_end{end_time:g}_{CASE.label()}.h5"
        )
    if run == "heavy":
        return RESULTS_DIR / f"dsph_bottom_slamming_heavy_{L0}_end{end_time:g}_{CASE.label()}.h5"
    f = float(run.removeprefix("mf"))
    return RESULTS_DIR / (
        f"dsph_bottom_slamming_light_{L0}_mf{f:g}_rtol0.001_ft{ft}_end{end_time:g}_"
        f"{CASE.label()}.h5"
    )


def prefix(run: str) -> str:
    """The results file's prefix of a run's PREFIX_TAGS ("rate_c075_", ...; "" for none)."""
    tags = run.split("_")[1:]
    return "".join(f"{t}_" for t in PREFIX_TAGS if t in tags)


def with_tags(run: str, light: list[str]) -> list[str]:
    """``light`` with the overrides of the run's PREFIX_TAGS added (a structure scheme's
    replacing the safeguards' HHT)."""
    tags = run.split("_")[1:]
    for tag, extra in PREFIX_TAGS.items():
        if tag not in tags:
            continue
        if any(o.startswith("structure.time.scheme") for o in extra):  # replaces the HHT
            light = [o for o in light if not o.startswith(SAFEGUARD_SCHEME)]
        light = light + extra
    return light


def aitken_force_tolerance(run: str) -> str:
    """The force tolerance of an Aitken run: 0.01 with the tag "_ft01", else 0.05."""
    return "0.01" if "ft01" in run.split("_") else "0.05"


def overrides(run: str, spacing: float, end_time: float, ft: str = "0.01") -> list[str]:
    if run in ("rigid", "rigid_x", "rigid_xw"):
        extra = {"rigid": [], "rigid_x": [EXCHANGE], "rigid_xw": [EXCHANGE, WETTED]}[run]
        return case_overrides("rigid", CASE, spacing) + [f"run.end_time={end_time!r}", *extra]
    if run in IMVJ_RUNS:  # the light plate as the obstacle at mass ratio 1e-4 under δ-SPH:
        # IQN-IMVJ's defaults, no fictitious mass (docs/validation_coupling_stress.md)
        tags = run.split("_")[1:]
        light = light_overrides(
            0.0,
            1e-3,
            force_tolerance="off",
            end_time=end_time,
            acceleration="iqn-imvj",
            kinematics="corotational" if "corot" in tags else "linear",
            safeguards="sg" in tags,
        )
        return case_overrides("elastic", CASE, spacing) + with_tags(run, light) + [WETTED]
    if run in AITKEN_RUNS:  # the MPS MF table's setting (potential-flow M_f 0.35, 3 Pa) with
        # the safeguards, wetted walls, and each tag's override (a floor, a shorter step)
        light = light_overrides(
            0.35,
            1e-3,
            max_iterations=100,
            force_tolerance=aitken_force_tolerance(run),
            end_time=end_time,
            model="potential_flow",
            wet_pressure=3.0,
            kinematics="corotational",
            safeguards=True,
        )
        return case_overrides("elastic", CASE, spacing) + with_tags(run, light) + [WETTED]
    if run == "heavy":  # the scenario's section, Aitken as the light runs, no M_f
        return case_overrides("elastic", CASE, spacing) + [
            f"run.end_time={end_time!r}",
            'coupling.acceleration.kind="aitken"',
        ]
    f = float(run.removeprefix("mf"))
    return case_overrides("elastic", CASE, spacing) + light_overrides(
        f, 1e-3, force_tolerance=ft, end_time=end_time
    )


#: s: the wave's arrival at the plate as the MPS runs measure it at A/H = 0.3 (first contact
#: 1.62-1.63 s, docs/validation_bottom_slamming_light.md). Under δ-SPH the plate's load has no
#: sharp contact: it rises from about 1.45 s (the rigid plate's pair exchange), as the kernel
#: (2h = 14.8 mm) reaches across the closing gap, so the iteration counts are given from this
#: time (:func:`wet_from`: shifted with the design crest for other amplitudes)
WET_FROM = 1.62


def wet_from(case: Case) -> float:
    """s: :data:`WET_FROM` moved by the design crest's arrival at the plate against that of
    A/H = 0.3 (the same clearance): 1.87, 1.62, 1.46, 1.34 s at A/H = 0.2, 0.3, 0.4, 0.5."""
    return WET_FROM + case.crest_time - Case(0.3, case.clearance).crest_time


def amplitude_of(results_file: str) -> float:
    """A/H of a results file's case label (``..._AH0.30_DH0.06.h5``)."""
    return float(results_file.split("_AH")[1].split("_")[0])


def coupling_split(path: Path, contact: float, prefix: str = "wet") -> dict[str, float]:
    """Iterations per window and unconverged windows before / from ``contact`` (s; a window's
    end time is /coupling/time, or (k + 1) x 1 ms in files without it); the accepted windows'
    force errors from ``contact`` on."""
    with h5py.File(path, "r") as h5:
        if "coupling" not in h5:
            return {}
        c = h5["coupling"]
        its = c["iterations"][:]
        conv = c["converged"][:]
        ferr = c["fictitious_force_error"][:] if "fictitious_force_error" in c else None
        t_end = c["time"][:] if "time" in c else (np.arange(its.size) + 1) * 1e-3
    wet = t_end >= contact if math.isfinite(contact) else np.zeros(its.size, bool)
    out = {
        f"{prefix}_windows": int(wet.sum()),
        f"{prefix}_it_mean": float(its[wet].mean()) if wet.any() else math.nan,
        f"{prefix}_it_max": int(its[wet].max()) if wet.any() else 0,
        f"{prefix}_unconverged": int(np.count_nonzero(conv[wet] == 0)),
    }
    if ferr is not None and wet.any():
        e = ferr[wet]
        e = e[np.isfinite(e)]
        if e.size:
            out[f"{prefix}_force_error_median"] = float(np.median(e))
            out[f"{prefix}_force_error_p90"] = float(np.percentile(e, 90))
    return out


def branch_time(path: Path) -> float:
    """s: where a light run's force tolerance 1e-2 starts: the end time of its base run (the
    ``_ftoff`` file of the same M_f, see :func:`branch`), 0 if there is none (run from t = 0)."""
    stem = path.name.replace("_ft0.01_end", "_ftoff_end").split("_end")[0]
    for base in sorted(RESULTS_DIR.glob(stem + "_end*.h5")):
        if not base.name.endswith(".ckpt.h5"):
            return float(base.name.split("_end")[1].split("_")[0])
    return 0.0


def report() -> int:
    rows = []
    refs: dict[str, tuple[float, float]] = {}  # run -> (raw, 11 ms mean) rigid peak
    for run in ("rigid", "rigid_x", "rigid_xw"):
        files = sorted(RESULTS_DIR.glob(f"dsph_bottom_slamming_{run}_{L0}_end*_{CASE.label()}.h5"))
        for path, _ in case_runner.readable_results(files):
            r = analyse(path)
            refs[run] = (r.peak_uplift, r.peak_uplift_smooth)
            with h5py.File(path, "r") as h5:
                t, fy = h5["probes"]["uplift"]["time"][:], h5["probes"]["uplift"]["value"][:, 1]
            dry = (t > 0.5) & (t < 1.0)  # still water under the plate (wave at x = 1.2 m later)
            rows.append(
                {
                    "run": run,
                    "a_over_h": CASE.ratio,
                    "d_over_h": CASE.clearance,
                    "results_file": path.name,
                    "status": r.status,
                    "t_end_s": r.t_end_s,
                    "dry_uplift_mean": float(fy[dry].mean()) if dry.any() else math.nan,
                    "contact_time_s": r.contact_time_s,
                    "peak_uplift": r.peak_uplift,
                    "peak_time_s": r.peak_time_s,
                    "peak_uplift_smooth": r.peak_uplift_smooth,
                    "peak_smooth_time_s": r.peak_smooth_time_s,
                    "steps": r.steps,
                    "wall_time_s": r.wall_time_s,
                }
            )
    # MF against the rigid plate's pair exchange, the measure the member's load is
    rigid_p, rigid_ps = refs.get("rigid", (math.nan, math.nan))
    for run in MF_REFERENCE:
        rigid, rigid_s = refs.get(MF_REFERENCE[run], (math.nan, math.nan))
        pattern = run_path(run, 0).name.replace("end0", "end*")
        for path, _ in case_runner.readable_results(sorted(RESULTS_DIR.glob(pattern))):
            with h5py.File(path, "r") as h5:
                t, fy = h5["probes"]["uplift"]["time"][:], h5["probes"]["uplift"]["value"][:, 1]
            dry = (t > 0.5) & (t < 1.0)
            dry_uplift = float(fy[dry].mean()) if dry.any() else math.nan
            if run == "heavy":
                b = analyse(path)
                row = {
                    "run": run,
                    "status": b.status,
                    "t_end_s": b.t_end_s,
                    "windows": b.windows,
                    "unconverged_windows": b.unconverged_windows,
                    "contact_time_s": b.contact_time_s,
                    "peak_uplift": b.peak_uplift,
                    "peak_time_s": b.peak_time_s,
                    "peak_uplift_smooth": b.peak_uplift_smooth,
                    "peak_smooth_time_s": b.peak_smooth_time_s,
                    "mid_disp_max_mm": b.mid_disp_max_mm,
                    "mid_disp_max_time_s": b.mid_disp_max_time_s,
                    "interface_work_error_pct": b.interface_work_error_pct,
                    "steps": b.steps,
                    "wall_time_s": b.wall_time_s,
                }
            else:
                r = analyse_light(path)
                row = {
                    "run": run,
                    "fictitious_mass": r.fictitious_mass,
                    "status": r.status,
                    "t_end_s": r.t_end_s,
                    "windows": r.windows,
                    "it_per_window_mean": r.it_per_window_mean,
                    "unconverged_windows": r.unconverged_windows,
                    "contact_time_s": r.contact_time_s,
                    "peak_uplift": r.peak_uplift,
                    "peak_time_s": r.peak_time_s,
                    "peak_uplift_smooth": r.peak_uplift_smooth,
                    "peak_smooth_time_s": r.peak_smooth_time_s,
                    "mid_disp_max_mm": r.mid_disp_max_mm,
                    "mid_disp_max_time_s": r.mid_disp_max_time_s,
                    "mid_disp_at_crest_mm": r.mid_disp_at_crest_mm,
                    "interface_work_error_pct": r.interface_work_error_pct,
                    "steps": r.steps,
                    "wall_time_s": r.wall_time_s,
                }
            row["a_over_h"] = CASE.ratio
            row["d_over_h"] = CASE.clearance
            row["results_file"] = path.name
            row["branch_at_s"] = branch_time(path) if run != "heavy" else math.nan
            row["dry_uplift_mean"] = dry_uplift
            row["mf_raw"] = row["peak_uplift"] / rigid
            row["mf_smooth"] = row["peak_uplift_smooth"] / rigid_s
            row.update(before_stop(path, row["status"], rigid_s))
            row["mf_raw_vs_pressure_integral"] = row["peak_uplift"] / rigid_p
            if run != "heavy":  # the windows at the force tolerance 1e-2 (after a branch)
                row.update(coupling_split(path, branch_time(path), "ft"))
            row.update(coupling_split(path, wet_from(CASE)))
            rows.append(row)
    if CSV.is_file():  # rows whose results file is not here are kept as they were
        have = {row["results_file"] for row in rows}
        kept = [r for r in read_csv(CSV) if r.get("results_file") not in have]
        for r in kept:  # rows written before the column (A/H = 0.3 then)
            r.setdefault("a_over_h", amplitude_of(r["results_file"]))
        rows = kept + rows
    if not rows:
        print("nothing to analyse")
        return 1
    columns = [
        "run", "a_over_h", "d_over_h", "fictitious_mass", "status", "t_end_s", "windows", "it_per_window_mean",
        "unconverged_windows", "branch_at_s", "ft_windows", "ft_it_mean", "ft_unconverged",
        "ft_force_error_median", "ft_force_error_p90", "wet_windows", "wet_it_mean", "wet_it_max",
        "wet_unconverged", "wet_force_error_median", "wet_force_error_p90", "dry_uplift_mean",
        "contact_time_s", "peak_uplift", "peak_time_s", "peak_uplift_smooth",
        "peak_smooth_time_s", "mf_raw", "mf_smooth", "mf_raw_vs_pressure_integral", "peak_smooth_before_stop",
        "peak_smooth_before_stop_time_s", "mf_smooth_before_stop", "mid_disp_at_crest_mm", "mid_disp_max_mm", "mid_disp_max_time_s",
        "interface_work_error_pct", "steps", "wall_time_s", "results_file",
    ]  # fmt: skip
    full = [{k: row.get(k, math.nan) for k in columns} for row in rows]
    write_csv(
        full,
        CSV,
        columns=columns,
        comment="validation/bottom_slamming_light_delta_sph.py: the light plate under δ-SPH, "
        "A/H = a_over_h, D/H = d_over_h, l0 = H/20; MF against the δ-SPH rigid plate's pair exchange "
        "(rigid_x, or rigid_xw with wetted walls); dry_uplift_mean: 0.5-1.0 s, still water under the plate",
    )
    for row in full:
        print(
            "  ".join(
                f"{k}={row[k]:.4g}" if isinstance(row[k], float) else f"{k}={row[k]}"
                for k in columns[:-1]
            )
        )
    print(f"wrote {CSV.relative_to(RESULTS_DIR.parents[1])}")
    return 0


#: s: what "before the stop" leaves out of a stopped run: its failing windows, whose rejected and
#: retried iterates load the plate with spikes (tens to hundreds of N/m against a few)
STOP_MARGIN = 0.02


def before_stop(path: Path, status: str, rigid_smooth: float) -> dict[str, float]:
    """The 11 ms running mean's largest uplift (N/m), its time (s) and MF against the rigid
    plate's 11 ms peak ``rigid_smooth``, up to STOP_MARGIN before a stop (the whole record of a
    finished run)."""
    with h5py.File(path, "r") as h5:
        t, fy = h5["probes"]["uplift"]["time"][:], h5["probes"]["uplift"]["value"][:, 1]
    smooth = smooth_force(t, fy)
    keep = t <= t[-1] - (0.0 if status == "finished" else STOP_MARGIN)
    masked = np.where(keep, smooth, np.nan)
    if not np.isfinite(masked).any():
        return {}
    k = int(np.nanargmax(masked))
    return {
        "peak_smooth_before_stop": float(smooth[k]),
        "peak_smooth_before_stop_time_s": float(t[k]),
        "mf_smooth_before_stop": float(smooth[k]) / rigid_smooth,
    }


def main(argv: list[str] | None = None) -> int:
    global CASE
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--runs", default="rigid", help=f"comma-separated of {', '.join(RUNS)}")
    ap.add_argument("--end-time", type=float, default=2.1, help="run.end_time, s (default 2.1)")
    ap.add_argument(
        "--branch-at",
        type=float,
        default=None,
        help="elastic runs: run to this time with --base-force-tolerance, then continue from "
        "its checkpoint there with the force tolerance 1e-2 (only run.* and "
        "coupling.convergence.* differ on a restart)",
    )
    ap.add_argument(
        "--base-force-tolerance",
        default="off",
        help='the base run\'s coupling.convergence.fictitious_force_tolerance (default "off")',
    )
    ap.add_argument(
        "--clearance",
        type=float,
        default=CASE.clearance,
        help=f"D/H of the plate (thesis: 0.03, 0.06, 0.10; default {CASE.clearance})",
    )
    ap.add_argument(
        "--amplitude",
        type=float,
        default=CASE.ratio,
        help=f"A/H of the solitary wave (the MF table's: 0.2, 0.3, 0.4, 0.5; default {CASE.ratio})",
    )
    case_runner.add_run_options(ap)
    args = ap.parse_args(argv)
    if args.clearance not in (0.03, 0.06, 0.1):
        ap.error(f"--clearance {args.clearance}: one of 0.03, 0.06, 0.1 (the thesis's)")
    if args.amplitude not in (0.2, 0.3, 0.4, 0.5):
        ap.error(f"--amplitude {args.amplitude}: one of 0.2, 0.3, 0.4, 0.5 (the MF table's)")
    CASE = Case(args.amplitude, args.clearance)
    runs = args.runs.split(",")
    bad = [r for r in runs if r not in RUNS]
    if bad:
        ap.error(f"--runs {args.runs}: {bad} not among {RUNS}")
    if not args.end_time > 0.0:
        ap.error(f"--end-time {args.end_time}: must be > 0")
    spacing = spacing_for(float(L0), DEPTH)
    print(f"l0 = {L0} m -> {spacing:.7g} m; M_f estimate {ADDED_MASS_ESTIMATE} kg/m^2")
    if not args.analyse_only:
        for run in runs:
            kind = "rigid" if run.startswith("rigid") else "elastic"
            out = run_path(run, args.end_time)
            if args.branch_at is not None and run.startswith("mf") and not out.exists():
                branch(run, spacing, out, args)
                continue
            case_runner.ensure_case(
                write_scenario(kind),
                out,
                overrides(run, spacing, args.end_time),
                args.threads,
                args.retry_failed,
                f"[dsph {run}]",
            )
    return report()


def branch(run: str, spacing: float, out: Path, args: argparse.Namespace) -> None:
    """Run the base of ``run`` to ``args.branch_at`` with the force tolerance
    ``args.base_force_tolerance`` (unless finished) and continue ``out`` from its checkpoint
    with the force tolerance 1e-2 to ``args.end_time`` (:func:`case_runner.branch_case`)."""
    ft0, at = args.base_force_tolerance, args.branch_at
    case_runner.branch_case(
        write_scenario("elastic"),
        run_path(run, at, ft0),
        overrides(run, spacing, at, ft0) + [f"output.checkpoint_interval={at!r}"],
        out,
        overrides(run, spacing, args.end_time),
        at,
        args.threads,
        args.retry_failed,
        f"[dsph {run}]",
    )


if __name__ == "__main__":
    sys.exit(main())
