"""The thesis's light bottom-slamming plate with the fictitious mass (issue 21, task H7).

scenarios/bottom_slamming_elastic_2d.toml with the section the thesis's tables imply
(A = 2.5e-5 m^2, I = 1e-9 m^4, rho = 1040 kg/m^3: 0.026 kg/m^2 per unit width;
docs/validation.md, "Choices", items 1 and 3), coupled by Aitken with the member's
``fictitious_mass`` set to a multiple of the estimated added mass of the plate's first wet mode
(:data:`ADDED_MASS_ESTIMATE`, derived by :func:`added_mass_estimate`). Each run is one
``mpsfem run`` subprocess (validation/case_runner.py: resumable, a finished file is skipped);
the overrides are validation/bottom_slamming.py's :func:`case_overrides` for the elastic plate
plus :func:`light_overrides`, and every measurement is that script's :func:`analyse` plus the
iterations per window. Writes validation/results/bottom_slamming_light.csv (one row per results
file found, MF against the rigid run of the same case and spacing in
validation/results/bottom_slamming_0.004.csv). The page
docs/validation_bottom_slamming_light.md quotes it.

    python validation/bottom_slamming_light.py [--l0 0.004] [--cases 0.3:0.06]
                                               [--mf 0.3,1] [--rtol 1e-3] [--threads 1]
                                               [--analyse-only] [--retry-failed]
    python validation/bottom_slamming_light.py --added-mass   # the estimate, printed
"""

from __future__ import annotations

import argparse
import fcntl
import math
import re
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import asdict, dataclass
from pathlib import Path

import h5py
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import case_runner  # noqa: E402
from bottom_slamming import (  # noqa: E402 - the rigid/elastic study's set-up and analysis
    DEPTH,
    PLATE_FRONT,
    PLATE_LENGTH,
    RESULTS_DIR,
    SCENARIOS,
    THESIS_MF,
    Case,
    analyse,
    case_overrides,
    parse_cases,
    running_mean,
    smooth_force,
    spacing_for,
)
from results_csv import read_csv, write_csv  # noqa: E402

CSV = RESULTS_DIR / "bottom_slamming_light.csv"
FIGURE = Path(__file__).resolve().parents[1] / "docs" / "figures" / "bottom_slamming_light.png"
#: the runs with the force-error criterion and the wetted-node M_f (task H1)
FIGURE_FORCE = FIGURE.with_name("bottom_slamming_light_force.png")
#: the runs of the shaped (potential-flow) M_f study and its lumped comparison (task H1, part 2:
#: files with "_pf", or branched at / ending at 1.55 / 1.85 s)
FIGURE_SHAPED = FIGURE.with_name("bottom_slamming_light_shaped.png")


def _shaped_study(path: Path) -> bool:
    m = NAME.search(path.name)
    return not _crest_study(path) and (
        bool(m["pf"]) or (m["end"] is not None and float(m["end"]) in (1.55, 1.85))
    )


#: the task H3 branches from the 1.85 s state of the potential-flow 0.5 / 1 Pa run (another
#: factor, threshold, frozen flags, acceleration or iteration limit, ending at 2.1 s or later),
#: plotted with that run to FIGURE_CREST
FIGURE_CREST = FIGURE.with_name("bottom_slamming_light_crest.png")


def _crest_study(path: Path, with_base: bool = False) -> bool:
    m = NAME.search(path.name)
    if not m["pf"] or m["end"] is None or float(m["end"]) < 2.1 or _other_case(path):
        return False
    base = float(m["mf"]) in (0.5, 1.0) and float(m["wp"] or 0) == 1.0
    base = base and float(m["end"]) == 2.1 and not (m["frz"] or m["acc"] or m["maxit"])
    return with_base and float(m["mf"]) == 0.5 if base else True


#: the co-rotational runs of the best D/H = 0.06 setting at the other clearances, with that run
#: (issue 21: "A/H = 0.3 at the three clearances first"), plotted to FIGURE_CLEARANCES
FIGURE_CLEARANCES = FIGURE.with_name("bottom_slamming_light_clearances.png")


def _other_clearance(path: Path) -> bool:
    """A run at a clearance other than D/H = 0.06 (every study before issue 21's three
    clearances ran 0.06 only)."""
    return not math.isclose(float(NAME.search(path.name)["d"]), 0.06)


def _other_amplitude(path: Path) -> bool:
    """A run at an amplitude other than A/H = 0.3 (the rest of the MF table, :data:`FIGURE_MF`;
    every study before it ran A/H = 0.3 only)."""
    return not math.isclose(float(NAME.search(path.name)["a"]), 0.3)


def _other_case(path: Path) -> bool:
    """Not A/H = 0.3, D/H = 0.06: kept out of the figures of that case's studies."""
    return _other_clearance(path) or _other_amplitude(path)


def _clearance_study(path: Path) -> bool:
    """The co-rotational, potential-flow runs from rest ending at 2.1 s or later, not branched
    from another run's state, at every clearance of A/H = 0.3 (the D/H = 0.06 ones also in
    FIGURE_CREST)."""
    m = NAME.search(path.name)
    corot = bool(m["corot"] and m["pf"] and not m["frm"]) and not _other_amplitude(path)
    return corot and float(m["end"] or 0.0) >= 2.1


AREA = 2.5e-5  # m^2, thesis Tables 5-3, 5-7
#: structure.time.hht_alpha of ``--safeguards`` (the obstacle's at mass ratio 1e-4)
SAFEGUARD_HHT_ALPHA = -0.3
SECOND_MOMENT = 1e-9  # m^4, thesis Tables 5-3, 5-7 read as 1e-9 (docs/validation.md item 3)
MEMBER_DENSITY = 1040.0  # kg/m^3, thesis Tables 5-3, 5-7
WATER_DENSITY = 1000.0  # kg/m^3, thesis Table 5-4
TANK_LENGTH = 2.5  # m, paddle face at rest to the end wall (scenario)
#: kg/m^2: the added mass of the light plate's first mode, sin(pi s / L), fully wetted from
#: below, free surface (p = 0) beside it, water depth H, tank walls at 0 and 2.5 m: the
#: Rayleigh quotient of potential flow solved by :func:`added_mass_estimate` (167.4 at h = 2 mm,
#: 167.6 at 1 mm). Rounded; the page derives it.
ADDED_MASS_ESTIMATE = 167.0


def added_mass_estimate(h: float = 0.002, wetted: float = 1.0, mode: str = "sin") -> float:
    """Added mass (kg/m^2) of the plate's mode w(s) per unit area by the Rayleigh quotient
    m_a = rho int(phi w) / int(w^2): phi the potential of unit normal acceleration w on the
    wetted part (length ``wetted`` x L from the front edge) of the still-water surface,
    phi = 0 on the rest of the surface (the high-frequency free-surface condition, the limit of
    an impact: Faltinsen 1990, Sea Loads, ch. 9), no flux through the bed (depth H) and the end
    walls; five-point finite differences on cells of ``h`` m. ``mode``: "sin" (the simply
    supported first mode sin(pi s / L)) or "heave" (w = 1)."""
    import scipy.sparse as sp
    import scipy.sparse.linalg as spl

    nx, ny = round(TANK_LENGTH / h), round(DEPTH / h)
    xc = (np.arange(nx) + 0.5) * h
    wet = (xc > PLATE_FRONT) & (xc < PLATE_FRONT + wetted * PLATE_LENGTH)
    shape = np.sin(np.pi * (xc - PLATE_FRONT) / PLATE_LENGTH) if mode == "sin" else np.ones(nx)
    w = np.where(wet, shape, 0.0)
    idx = np.arange(nx * ny).reshape(ny, nx)  # row 0 the bed, row ny - 1 the surface
    diag = np.zeros((ny, nx))
    rows, cols = [], []
    for di, dj in ((1, 0), (-1, 0), (0, 1), (0, -1)):
        i0, i1 = max(0, -di), nx - max(0, di)
        j0, j1 = max(0, -dj), ny - max(0, dj)
        rows.append(idx[j0:j1, i0:i1].ravel())
        cols.append(idx[j0 + dj : j1 + dj, i0 + di : i1 + di].ravel())
        diag[j0:j1, i0:i1] -= 1.0
    b = np.zeros((ny, nx))
    # surface face: Neumann dphi/dy = w on the wetted part (ghost phi + h w), else phi = 0
    diag[-1, :] -= np.where(wet, 0.0, 2.0)
    b[-1, :] -= np.where(wet, w * h, 0.0)
    n = nx * ny
    a = sp.csr_matrix(
        (
            np.concatenate([np.ones(sum(r.size for r in rows)), diag.ravel()]),
            (np.concatenate([*rows, np.arange(n)]), np.concatenate([*cols, np.arange(n)])),
        ),
        shape=(n, n),
    )
    phi = spl.spsolve(a.tocsc(), b.ravel()).reshape(ny, nx)
    phi_surface = phi[-1] + 0.5 * h * w  # at the face, half a cell above the top centres
    return float(WATER_DENSITY * abs(np.sum(phi_surface * w)) / np.sum(w[wet] ** 2))


def branch_time(source: Path) -> float:
    """The time (s) of the state a ``--branch-from`` run continues: that of ``source``'s
    checkpoint (the one :func:`case_runner.physics_branch` copies)."""
    from mpsfem.results.checkpoint import default_checkpoint_path, read_checkpoint

    ckpt = default_checkpoint_path(source)
    if not ckpt.is_file():
        raise SystemExit(f"--branch-from {source}: no checkpoint {ckpt.name} beside it")
    _, meta, _ = read_checkpoint(ckpt)
    return float(meta["scheme"]["t"])


def light_overrides(
    mf_factor: float,
    rtol: float,
    relative_to: str = "displacement",
    max_iterations: int = 30,
    force_tolerance: str | None = None,
    end_time: float | None = None,
    model: str = "lumped",
    wet_pressure: float = 0.0,
    wet_update: str = "window",
    freeze: bool = False,
    acceleration: str = "aitken",
    kinematics: str = "linear",
    safeguards: bool = False,
    collision_ramp: float = 0.0,
    wet_margin: int = 1,
) -> list[str]:
    """The light section, the fictitious mass (``mf_factor`` x the estimate), Aitken and the
    convergence measure (rtol relative to the whole displacement or to the window's motion);
    ``force_tolerance`` (a number or "off"), coupling.convergence.fictitious_force_tolerance
    (None: the schema's default); ``end_time`` (s), run.end_time (None: the case's); ``model``
    the member's fictitious_mass_model ("potential_flow": ``mf_factor`` x the wetted patch's
    potential-flow added-mass operator, task H1 of issue 21); ``wet_update`` the member's
    fictitious_wet_update ("grow": the wet set grows inside a window, task H5); ``freeze``
    fluid.surface.freeze_in_coupling_window (its default rule "settled"); ``acceleration`` the
    coupling.acceleration.kind (task H3: after the crest); ``kinematics`` the member's
    ("corotational": large rotations, the runs past the crest rotate 0.5 rad); ``safeguards``
    what took the obstacle at mass ratio 1e-4 to its end (docs/validation_coupling_stress.md):
    coupling.convergence.accept_unconverged = "best", retreat_predictor = true and the HHT
    integrator with alpha = -0.3; ``collision_ramp`` fluid.collision.ramp (a contact load
    continuous in the member's displacement; docs/coupler.md, "Contact that fades in");
    ``wet_margin`` the member's fictitious_wet_margin (elements around the loaded nodes that
    carry M_f too; 1 the schema's default)."""
    extra = []
    if wet_margin != 1:
        extra.append(f"structure.members.0.fictitious_wet_margin={int(wet_margin)}")
    if collision_ramp > 0.0:
        extra.append(f"fluid.collision.ramp={float(collision_ramp)!r}")
    if safeguards:
        extra += [
            'coupling.convergence.accept_unconverged="best"',
            "coupling.convergence.retreat_predictor=true",
            'structure.time.scheme="hht"',
            f"structure.time.hht_alpha={SAFEGUARD_HHT_ALPHA!r}",
        ]
    if kinematics != "linear":
        extra.append(f'structure.members.0.kinematics="{kinematics}"')
    if freeze:
        extra.append("fluid.surface.freeze_in_coupling_window=true")
    if wet_update != "window":
        extra.append(f'structure.members.0.fictitious_wet_update="{wet_update}"')
    if model != "lumped":
        extra.append(f'structure.members.0.fictitious_mass_model="{model}"')
    if wet_pressure > 0.0:
        extra.append(f"structure.members.0.fictitious_wet_pressure={float(wet_pressure)!r}")
    mf = mf_factor if model == "potential_flow" else mf_factor * ADDED_MASS_ESTIMATE
    if force_tolerance is not None:
        ft = force_tolerance if force_tolerance == "off" else float(force_tolerance)
        extra.append(f"coupling.convergence.fictitious_force_tolerance={ft!r}".replace("'", '"'))
    if end_time is not None:
        extra.append(f"run.end_time={float(end_time)!r}")
    return extra + [
        f"structure.members.0.area={AREA!r}",
        f"structure.members.0.second_moment={SECOND_MOMENT!r}",
        f"structure.members.0.fictitious_mass={mf!r}",
        f'coupling.acceleration.kind="{acceleration}"',
        f"coupling.convergence.relative_tolerance={rtol!r}",
        f'coupling.convergence.relative_to="{relative_to}"',
        f"coupling.convergence.max_iterations={max_iterations}",
    ]


def run_path(
    l0_label: str,
    case: Case,
    mf_factor: float,
    rtol: float,
    relative_to: str = "displacement",
    max_iterations: int = 30,
    force_tolerance: str | None = None,
    end_time: float | None = None,
    model: str = "lumped",
    wet_pressure: float = 0.0,
    wet_update: str = "window",
    freeze: bool = False,
    acceleration: str = "aitken",
    kinematics: str = "linear",
    branched_from: float | None = None,
    safeguards: bool = False,
    collision_ramp: float = 0.0,
    wet_margin: int = 1,
) -> Path:
    """The results file of a run. Names without ``_ft``: runs of the code before the
    force-error criterion and the wetted-node M_f (issue 21, task H1); with ``_pf``: the
    potential-flow M_f (``mf`` its factor, not a multiple of the estimate); with ``_grow``: the
    wet set grown inside windows (fictitious_wet_update = "grow", task H5); with ``_frz``: surface
    flags frozen in a window; with ``_acc<kind>``: an acceleration other than Aitken (task H3);
    with ``_corot``: a co-rotational member; with ``_sg``: the obstacle's safeguards (best
    iterate, retreating predictor, HHT -0.3; :func:`light_overrides`); with ``_ramp<r>``: the
    collision ramp r; with ``_mg<k>``: the wet margin k elements (fictitious_wet_margin; 1 the
    default, no token); with ``_from<t>``: a ``--branch-from`` run, continued
    from another run's state at t s (runs of task H3 before this token carry no such mark)."""
    wm = "wm" if relative_to == "window_motion" else ""
    if max_iterations != 30:  # the scenario's
        wm += f"it{max_iterations}"
    if model == "potential_flow":
        wm += "_pf"
    if wet_pressure > 0.0:
        wm += f"_wp{wet_pressure:g}"
    if wet_update != "window":
        wm += f"_{wet_update}"
    if freeze:
        wm += "_frz"
    if acceleration != "aitken":
        wm += f"_acc{acceleration}"
    if kinematics == "corotational":
        wm += "_corot"
    if safeguards:
        wm += "_sg"
    if collision_ramp > 0.0:
        wm += f"_ramp{collision_ramp:g}"
    if wet_margin != 1:
        wm += f"_mg{int(wet_margin)}"
    if force_tolerance is not None:
        wm += f"_ft{force_tolerance if force_tolerance == 'off' else f'{float(force_tolerance):g}'}"
    if end_time is not None:
        wm += f"_end{end_time:g}"
    if branched_from is not None:
        wm += f"_from{branched_from:g}"
    return RESULTS_DIR / (
        f"bottom_slamming_light_{l0_label}_mf{mf_factor:g}_rtol{rtol:g}{wm}_{case.label()}.h5"
    )


NAME = re.compile(
    r"bottom_slamming_light_(?P<l0>[0-9.e-]+)_mf(?P<mf>[0-9.e-]+)_rtol(?P<rtol>[0-9.e-]+)(?P<wm>(wm)?)(?:it(?P<maxit>[0-9]+))?"
    r"(?P<pf>_pf)?(?:_wp(?P<wp>[0-9.e-]+))?(?P<grow>_grow)?(?P<frz>_frz)?(?:_acc(?P<acc>[a-z-]+))?(?P<corot>_corot)?(?P<sg>_sg)?(?:_ramp(?P<ramp>[0-9.e-]+))?(?:_mg(?P<mg>[0-9]+))?(?:_ft(?P<ft>off|[0-9.e-]+))?(?:_end(?P<end>[0-9.e-]+))?(?:_from(?P<frm>[0-9.e-]+))?_"
    r"AH(?P<a>[0-9.]+)_DH(?P<d>[0-9.]+)\.h5$"
)


@dataclass
class LightResult:
    """One row of validation/results/bottom_slamming_light.csv (N/m, s, mm)."""

    l0_label: str
    l0: float
    a_over_h: float
    d_over_h: float
    mf_factor: float  # fictitious mass / ADDED_MASS_ESTIMATE
    fictitious_mass: float  # kg/m^2 (lumped); NaN for the potential-flow operator
    rtol: float
    relative_to: str  # the convergence measure: "displacement" or "window_motion"
    max_iterations: int  # per window (the scenario: 30)
    # coupling.convergence.fictitious_force_tolerance; "none": code before the criterion and
    # the wetted-node M_f (M_f on every node)
    force_tolerance: str
    status: str
    t_end_s: float
    windows: int
    it_per_window_mean: float
    it_per_window_max: int
    unconverged_windows: int
    contact_time_s: float
    peak_uplift: float
    peak_time_s: float
    peak_uplift_smooth: float  # 11 ms running mean
    peak_smooth_time_s: float
    uplift_impulse: float
    rigid_peak: float  # bottom_slamming_<RIGID_L0>.csv, same case (NaN where none)
    rigid_peak_smooth: float
    mf_raw: float
    mf_smooth: float
    thesis_mf: float
    mid_disp_max_mm: float
    mid_disp_min_mm: float
    mid_disp_max_time_s: float
    mid_disp_at_crest_mm: float  # at t_c, the design crest at the front edge
    mid_velocity_last_mm_s: float  # mean mid-span velocity over the record's last 0.1 s
    interface_work_error_pct: float
    steps: int
    wall_time_s: float
    results_file: str = ""  # its name (the row's key when the CSV is merged)
    fictitious_mass_model: str = "lumped"  # "potential_flow": mf_factor x the operator
    wet_pressure_pa: float = 0.0  # structure.members.0.fictitious_wet_pressure
    # windows ending from WET_FROM on: count, iterations mean, unconverged, and the accepted
    # windows' fictitious force error / load scale (median, 90 %)
    wet_windows: int = 0
    wet_it_mean: float = math.nan
    wet_unconverged: int = 0
    wet_force_error_median: float = math.nan
    wet_force_error_p90: float = math.nan
    # structure.members.0.fictitious_wet_update, and the windows ending from WET_FROM on whose
    # wet set grew inside them and the growths in all (/coupling/fictitious_set_growths)
    wet_update: str = "window"
    wet_windows_grown: int = 0
    wet_set_growths: int = 0
    # task H3: fluid.surface.freeze_in_coupling_window, coupling.acceleration.kind, and the
    # windows ending after LATE_FROM (1.85 s: the branches' start) and after CREST_FROM (2.0 s:
    # after the crest): count, iterations mean, unconverged
    freeze_surface: bool = False
    acceleration: str = "aitken"
    kinematics: str = "linear"  # the member's
    safeguards: bool = False  # --safeguards (file name _sg)
    collision_ramp: float = 0.0  # --collision-ramp (file name _ramp<r>)
    wet_margin: int = 1  # --wet-margin (file name _mg<k>)
    branched_from_s: float = math.nan  # --branch-from: the time of the state it continued
    # the start of the wet split (s): WET_FROM at D/H = 0.06, else the first wet set
    # (:func:`wet_from`)
    wet_from_s: float = math.nan
    # the rigid run of the same case at the row's own spacing (bottom_slamming_<l0>.csv; NaN
    # where none) and MF against it, raw and in 11 ms means
    rigid_peak_same_l0: float = math.nan
    rigid_peak_smooth_same_l0: float = math.nan
    mf_raw_same_l0: float = math.nan
    mf_smooth_same_l0: float = math.nan
    # the plate on its way back (issue 21's "second slam"): the largest uplift after the
    # mid-span maximum up to the window end, raw and in 11 ms means, and when the mid-span first
    # comes back to its rest level (uy <= 0) after that maximum (NaN: not within the record)
    return_peak: float = math.nan
    return_peak_time_s: float = math.nan
    return_peak_smooth: float = math.nan
    return_peak_smooth_time_s: float = math.nan
    mid_back_at_rest_s: float = math.nan
    late_windows: int = 0
    late_it_mean: float = math.nan
    late_unconverged: int = 0
    crest_windows: int = 0
    crest_it_mean: float = math.nan
    crest_unconverged: int = 0


#: the rigid runs MF divides by: bottom_slamming_<RIGID_L0>.csv (there are none at H/20; the
#: coarse runs' MF is against this spacing's rigid peak, a different lattice)
RIGID_L0 = "0.004"


def rigid_reference(case: Case, l0_label: str = RIGID_L0) -> tuple[float, float]:
    """(raw, 11 ms mean) rigid peak (N/m) of the case from bottom_slamming_<l0_label>.csv, NaN
    if none."""
    path = RESULTS_DIR / f"bottom_slamming_{l0_label}.csv"
    if not path.is_file():
        return math.nan, math.nan
    for r in read_csv(path):
        if (
            r["kind"] == "rigid"
            and math.isclose(float(r["a_over_h"]), case.ratio)
            and math.isclose(float(r["d_over_h"]), case.clearance)
        ):
            return float(r["peak_uplift"]), float(r["peak_uplift_smooth"])
    return math.nan, math.nan


def analyse_light(path: Path) -> LightResult:
    m = NAME.search(path.name)
    if m is None:
        raise ValueError(f"{path.name}: not a bottom_slamming_light results file")
    base = analyse(path)
    with h5py.File(path, "r") as h5:
        its = h5["coupling"]["iterations"][:] if "coupling" in h5 else np.zeros(0, int)
        td = h5["probes"]["plate_mid"]["time"][:]
        uy = h5["probes"]["plate_mid"]["value"][:, 1]
    case = Case(base.a_over_h, base.d_over_h)
    rigid, rigid_s = rigid_reference(case)
    same, same_s = rigid_reference(case, m["l0"])
    mf = float(m["mf"])
    pf = bool(m["pf"])
    wet = wet_split(path, case)
    back = return_load(path, case)
    last = td >= td[-1] - 0.1
    velocity = (uy[last][-1] - uy[last][0]) / max(td[last][-1] - td[last][0], 1e-12)
    return LightResult(
        l0_label=m["l0"],
        l0=base.l0,
        a_over_h=base.a_over_h,
        d_over_h=base.d_over_h,
        mf_factor=mf,
        fictitious_mass=math.nan if pf else mf * ADDED_MASS_ESTIMATE,
        rtol=float(m["rtol"]),
        relative_to="window_motion" if m["wm"] else "displacement",
        max_iterations=int(m["maxit"] or 30),
        force_tolerance=m["ft"] or "none",
        status=base.status,
        t_end_s=base.t_end_s,
        windows=int(its.size),
        it_per_window_mean=float(its.mean()) if its.size else math.nan,
        it_per_window_max=int(its.max()) if its.size else 0,
        unconverged_windows=base.unconverged_windows,
        contact_time_s=base.contact_time_s,
        peak_uplift=base.peak_uplift,
        peak_time_s=base.peak_time_s,
        peak_uplift_smooth=base.peak_uplift_smooth,
        peak_smooth_time_s=base.peak_smooth_time_s,
        uplift_impulse=base.uplift_impulse,
        rigid_peak=rigid,
        rigid_peak_smooth=rigid_s,
        mf_raw=base.peak_uplift / rigid,
        mf_smooth=base.peak_uplift_smooth / rigid_s,
        thesis_mf=THESIS_MF.get((case.ratio, case.clearance), math.nan),
        mid_disp_max_mm=base.mid_disp_max_mm,
        mid_disp_min_mm=base.mid_disp_min_mm,
        mid_disp_max_time_s=base.mid_disp_max_time_s,
        mid_disp_at_crest_mm=float(np.interp(case.crest_time, td, uy)) * 1e3,
        mid_velocity_last_mm_s=float(velocity) * 1e3,
        interface_work_error_pct=base.interface_work_error_pct,
        steps=base.steps,
        wall_time_s=base.wall_time_s,
        results_file=path.name,
        fictitious_mass_model="potential_flow" if pf else "lumped",
        wet_pressure_pa=float(m["wp"] or 0.0),
        wet_update="grow" if m["grow"] else "window",
        freeze_surface=bool(m["frz"]),
        acceleration=m["acc"] or "aitken",
        kinematics="corotational" if m["corot"] else "linear",
        safeguards=bool(m["sg"]),
        collision_ramp=float(m["ramp"] or 0.0),
        wet_margin=int(m["mg"]) if m["mg"] else 1,
        branched_from_s=float(m["frm"]) if m["frm"] else math.nan,
        rigid_peak_same_l0=same,
        rigid_peak_smooth_same_l0=same_s,
        mf_raw_same_l0=base.peak_uplift / same,
        mf_smooth_same_l0=base.peak_uplift_smooth / same_s,
        **back,
        **wet,
    )


def return_load(path: Path, case: Case) -> dict:
    """The plate on its way back down: after the mid-span's largest upward displacement (to
    the window end :attr:`Case.reflection_time`), the largest uplift (N/m) raw and in 11 ms
    running means and their times (s), and the first time the mid-span is back at or below its
    rest level. Empty where the record ends at that maximum."""
    with h5py.File(path, "r") as h5:
        t, fy = h5["probes"]["uplift"]["time"][:], h5["probes"]["uplift"]["value"][:, 1]
        td, uy = h5["probes"]["plate_mid"]["time"][:], h5["probes"]["plate_mid"]["value"][:, 1]
    w_end = case.reflection_time
    dsel = td <= w_end
    if not dsel.any():
        return {}
    j = int(np.argmax(np.where(dsel, uy, -np.inf)))
    after = (t > td[j]) & (t <= w_end)
    if not after.any():
        return {}
    smooth = smooth_force(t, fy)
    i = int(np.argmax(np.where(after, fy, -np.inf)))
    masked = np.where(after, smooth, np.nan)
    # the running mean is undefined within half its width of the record's end
    k = int(np.nanargmax(masked)) if np.isfinite(masked).any() else -1
    down = np.flatnonzero(dsel & (np.arange(td.size) > j) & (uy <= 0.0))
    return {
        "return_peak": float(fy[i]),
        "return_peak_time_s": float(t[i]),
        "return_peak_smooth": float(smooth[k]) if k >= 0 else math.nan,
        "return_peak_smooth_time_s": float(t[k]) if k >= 0 else math.nan,
        "mid_back_at_rest_s": float(td[down[0]]) if down.size else math.nan,
    }


#: s: the first wet window's end at H/20 (dry, 1 iteration per window, before: the page's
#: "wet windows (1.61-2.1 s)")
WET_FROM = 1.61
#: s: the 1.85 s checkpoint the task H3 branches start from, and the end of the crest's passage
#: over the plate (t_c = 1.953 s): windows ending after these
LATE_FROM = 1.85
CREST_FROM = 2.0


def wet_from(case: Case, t: np.ndarray, ferr: np.ndarray | None) -> float:
    """Start (s) of a run's wet windows: :data:`WET_FROM` at A/H = 0.3, D/H = 0.06 (every row
    before the other cases, kept so they stay comparable); in another case contact comes
    earlier or later, so the end of the first window ``t`` with a nonempty fictitious wet set (a
    finite fictitious force error ``ferr``), NaN where there is none (no wet window, or a file
    without the column)."""
    if math.isclose(case.clearance, 0.06) and math.isclose(case.ratio, 0.3):
        return WET_FROM
    if ferr is None or ferr.size != t.size or not np.isfinite(ferr).any():
        return math.nan
    return float(t[np.argmax(np.isfinite(ferr))])


def wet_split(path: Path, case: Case) -> dict:
    """Windows ending at or after :func:`wet_from`: count, iterations mean, unconverged, and the
    fictitious force error / load scale of the accepted ones (median, 90th percentile)."""
    with h5py.File(path, "r") as h5:
        if "coupling" not in h5:
            return {}
        c = h5["coupling"]
        t = c["time"][:]
        its, conv = c["iterations"][:], c["converged"][:]
        ferr = c["fictitious_force_error"][:] if "fictitious_force_error" in c else None
        grown = c["fictitious_set_growths"][:] if "fictitious_set_growths" in c else None
    start = wet_from(case, t, ferr)
    wet = t >= start - 1e-9  # all False for NaN
    if not wet.any():
        return {}
    out = {
        "wet_from_s": start,
        "wet_windows": int(wet.sum()),
        "wet_it_mean": float(its[wet].mean()),
        "wet_unconverged": int(np.count_nonzero(conv[wet] == 0)),
    }
    for name, start in (("late", LATE_FROM), ("crest", CREST_FROM)):
        sel = t > start + 1e-9
        if sel.any():
            out[f"{name}_windows"] = int(sel.sum())
            out[f"{name}_it_mean"] = float(its[sel].mean())
            out[f"{name}_unconverged"] = int(np.count_nonzero(conv[sel] == 0))
    if grown is not None and grown.size == t.size:
        g = np.nan_to_num(grown[wet])
        out["wet_windows_grown"] = int(np.count_nonzero(g > 0))
        out["wet_set_growths"] = int(g.sum())
    if ferr is not None and ferr.size != t.size:
        # written before results_file padded a window without a force error with NaN: the
        # column is shorter than /coupling/time and cannot be aligned with it
        ferr = None
    if ferr is not None:
        e = ferr[wet]
        e = e[np.isfinite(e)]
        if e.size:
            out["wet_force_error_median"] = float(np.median(e))
            out["wet_force_error_p90"] = float(np.percentile(e, 90))
    return out


def plot(
    paths: list[Path],
    out: Path,
    xlim: tuple[float, float] = (-0.4, 0.8),
    title: str = "Light plate (0.026 kg/m^2), A/H = 0.3, D/H = 0.06, Aitken + fictitious mass",
    ylim: tuple[float, float] = (-30.0, 80.0),
) -> None:
    """Uplift (11 ms running mean, every sample light) and mid-span displacement against
    t - t_c of every results file, one colour each (labelled with D/H where they differ)."""
    clearances = {NAME.search(p.name)["d"] for p in paths}
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (ax_f, ax_d) = plt.subplots(2, 1, figsize=(7.0, 5.5), sharex=True)
    for n, path in enumerate(paths):
        r = NAME.search(path.name)
        case = Case(float(r["a"]), float(r["d"]))
        label = f"l0 {r['l0']}, M_f {float(r['mf']):g}x, rtol {float(r['rtol']):g}{r['wm']}"
        if len(clearances) > 1:
            label = f"D/H = {float(r['d']):g}, {label}"
        if r["maxit"]:
            label += f", {r['maxit']} it."
        label += f", force tol. {r['ft']}" if r["ft"] else ", old code"
        if r["pf"]:
            label = label.replace("M_f", "potential-flow M_f")
        if r["wp"]:
            label += f", wet > {float(r['wp']):g} Pa"
        if r["frz"]:
            label += ", frozen flags"
        if r["acc"]:
            label += f", {r['acc']}"
        with h5py.File(path, "r") as h5:
            t, f = h5["probes"]["uplift"]["time"][:], h5["probes"]["uplift"]["value"][:, 1]
            td, u = h5["probes"]["plate_mid"]["time"][:], h5["probes"]["plate_mid"]["value"][:, 1]
        c = f"C{n}"
        ax_f.plot(t - case.crest_time, f, color=c, lw=0.3, alpha=0.3)
        ax_f.plot(t - case.crest_time, running_mean(f, 11), color=c, lw=1.0, label=label)
        ax_d.plot(td - case.crest_time, u * 1e3, color=c, lw=1.0, label=label)
    ax_f.set_ylabel(f"uplift (N/m), clipped to {ylim[0]:g} ... {ylim[1]:g}")
    ax_f.set_ylim(*ylim)  # a diverging window's spike would hide the rest
    ax_d.set_ylabel("mid-span uy (mm)")
    ax_d.set_xlabel("t - t_c (s)")
    ax_f.set_xlim(*xlim)
    for ax in (ax_f, ax_d):
        ax.grid(alpha=0.3)
        ax.axhline(0.0, color="0.6", lw=0.4)
    ax_f.legend(fontsize=7)
    fig.suptitle(title)
    fig.tight_layout()
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=80)
    plt.close(fig)


@contextmanager
def _csv_lock() -> Iterator[None]:
    """Hold an exclusive lock (``<CSV>.lock`` beside it) while reading, merging and writing the
    CSV: runs finishing at once each merge their rows into it, and without the lock one read
    the other's half-written file and dropped rows (2026-11-26)."""
    CSV.parent.mkdir(parents=True, exist_ok=True)
    with open(CSV.with_name(CSV.name + ".lock"), "w") as handle:
        fcntl.flock(handle, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(handle, fcntl.LOCK_UN)


def report() -> int:
    rows, paths = [], []
    files = sorted(RESULTS_DIR.glob("bottom_slamming_light_*.h5"))
    for path, _ in case_runner.readable_results(files):
        try:
            rows.append(analyse_light(path))
            paths.append(path)
        except (KeyError, ValueError) as exc:
            print(f"{path.name}: cannot analyse ({exc})")
    if not rows:
        print("nothing to analyse")
        return 1
    # the CSV's rows whose results files are not here stay as they are (merged by file name)
    found = {r.results_file for r in rows}
    with _csv_lock():  # two runs finishing at once each merge into the CSV
        kept = [r for r in (read_csv(CSV) if CSV.is_file() else []) if _row_file(r) not in found]
        for r in kept:
            r.setdefault("force_tolerance", "none")
            r.setdefault("fictitious_mass_model", "lumped")
            r.setdefault("wet_pressure_pa", 0.0)
            r.setdefault("wet_update", "window")
            r.setdefault("wet_windows_grown", 0)
            r.setdefault("wet_set_growths", 0)
            r.setdefault("freeze_surface", False)
            r.setdefault("acceleration", "aitken")
            r.setdefault("kinematics", "linear")
            r.setdefault("safeguards", False)
            r.setdefault("collision_ramp", 0.0)
            r.setdefault("wet_margin", 1)
            r.setdefault("branched_from_s", math.nan)
            for k in ("return_peak", "return_peak_time_s", "return_peak_smooth",
                      "return_peak_smooth_time_s", "mid_back_at_rest_s"):  # fmt: skip
                r.setdefault(k, math.nan)  # needs the results file
            r["results_file"] = _row_file(r)
            if not r.get("wet_from_s"):
                # rows before the column: every one is at D/H = 0.06, split at WET_FROM if at all
                r["wet_from_s"] = (
                    WET_FROM if r.get("wet_windows") not in ("", None, "0") else math.nan
                )
            # the same-spacing rigid run may have come since the row was written: looked up anew
            same, same_s = rigid_reference(
                Case(float(r["a_over_h"]), float(r["d_over_h"])), r["l0_label"]
            )
            r["rigid_peak_same_l0"], r["rigid_peak_smooth_same_l0"] = same, same_s
            r["mf_raw_same_l0"] = float(r["peak_uplift"]) / same
            r["mf_smooth_same_l0"] = float(r["peak_uplift_smooth"]) / same_s
        merged = [asdict(r) for r in rows] + kept
        merged.sort(key=lambda r: (-float(r["l0"]), float(r["a_over_h"]), float(r["d_over_h"]),
                                   float(r["rtol"]), float(r["mf_factor"]), r["results_file"]))  # fmt: skip
        write_csv(
            merged,
            CSV,
            columns=list(LightResult.__dataclass_fields__),
            comment="validation/bottom_slamming_light.py: the light plate with the fictitious mass",
        )
    clear = [p for p in paths if _clearance_study(p)]
    if clear:
        # one spacing and factor, the one run at the most clearances (coarsest first on a tie:
        # the study's H/20), and per clearance its longest run (a shorter one is its prefix)
        groups: dict[tuple[str, str], dict[str, Path]] = {}
        for p in clear:
            m = NAME.search(p.name)
            longest = groups.setdefault((m["l0"], m["mf"]), {})
            if m["d"] not in longest or float(m["end"]) > float(
                NAME.search(longest[m["d"]].name)["end"]
            ):
                longest[m["d"]] = p
        (l0, mf), longest = max(groups.items(), key=lambda g: (len(g[1]), float(g[0][0])))
        clear = [longest[d] for d in sorted(longest, key=float)]
        last = max(float(NAME.search(p.name)["end"]) for p in clear)
        plot(clear, FIGURE_CLEARANCES, xlim=(-0.4, last - Case(0.3, 0.06).crest_time + 0.01),
             title=f"Light plate, co-rotational, A/H = 0.3, l0 = {l0} m, "
             f"factor {mf}",
             ylim=(-5.0, 10.0))  # fmt: skip
    paths = [p for p in paths if not _other_case(p)]  # the figures below: A/H 0.3, D/H 0.06
    shaped = [p for p in paths if _shaped_study(p)]
    crest = [p for p in paths if _crest_study(p, with_base=True)]
    rest = [p for p in paths if not _shaped_study(p) and not _crest_study(p, with_base=True)]
    if crest:
        last = max(float(NAME.search(p.name)["end"]) for p in crest)
        plot(crest, FIGURE_CREST, xlim=(-0.11, last - Case(0.3, 0.06).crest_time + 0.005))
    old = [p for p in rest if not NAME.search(p.name)["ft"]]
    new = [p for p in rest if NAME.search(p.name)["ft"]]
    for group, fig in ((old, FIGURE), (new, FIGURE_FORCE)):
        if group:
            plot(group, fig)
    shaped = [p for p in shaped if float(NAME.search(p.name)["end"] or 0.0) != 1.55]  # no bases
    if shaped:
        last = max(float(NAME.search(p.name)["end"] or 1.85) for p in shaped)
        plot(shaped, FIGURE_SHAPED, xlim=(-0.35, last - Case(0.3, 0.06).crest_time + 0.01))
    keys = ("l0", "d_over_h", "mf_factor", "rtol", "relative_to", "max_iterations", "force_tolerance", "status", "t_end_s", "it_per_window_mean",
            "it_per_window_max", "unconverged_windows", "peak_uplift", "peak_uplift_smooth",
            "mf_raw", "mf_smooth", "mid_disp_max_mm", "wall_time_s")  # fmt: skip
    for r in rows:
        d = asdict(r)
        print(
            "  ".join(f"{k}={d[k]:.4g}" if isinstance(d[k], float) else f"{k}={d[k]}" for k in keys)
        )
    table = mf_table(merged)
    if table:
        write_csv(table, MF_TABLE_CSV, comment="validation/bottom_slamming_light.py: the light "
                  f"plate's MF table at l0 = {MF_TABLE_L0} m (MF_TABLE_SETTING)")  # fmt: skip
        plot_mf_table(table, FIGURE_MF)
        print_mf_table(table)
    print(f"wrote {CSV.relative_to(RESULTS_DIR.parents[1])} and the figures of the runs found")
    return 0


#: the 12-case MF table (issue 21: "the whole 12-case MF table at l0 = 0.004 m beside the
#: thesis's"): the setting of the three clearances at A/H = 0.3 (co-rotational member,
#: potential-flow M_f factor 0.35, wet threshold 3 Pa, force tolerance 5e-2, Aitken, rtol 1e-3
#: of the displacement, at most 100 iterations), run from rest in every case at one spacing
MF_TABLE_CSV = RESULTS_DIR / "bottom_slamming_light_mf_table.csv"
FIGURE_MF = FIGURE.with_name("bottom_slamming_light_mf.png")
MF_TABLE_L0 = "0.004"
MF_TABLE_SETTING = {
    "kinematics": "corotational",
    "fictitious_mass_model": "potential_flow",
    "mf_factor": 0.35,
    "wet_pressure_pa": 3.0,
    "force_tolerance": "0.05",
    "max_iterations": 100,
    "rtol": 1e-3,
    "relative_to": "displacement",
    "acceleration": "aitken",
    "wet_update": "window",
    "freeze_surface": False,
    "safeguards": False,
}


def _num(v: object) -> float:
    """A CSV cell (or a value) as a float; blank -> NaN."""
    return math.nan if v in ("", None) else float(v)  # type: ignore[arg-type]


def _in_table_setting(row: dict, safeguards: bool = False) -> bool:
    """A row of the MF table's setting at :data:`MF_TABLE_L0`, run from rest (not branched);
    ``safeguards``: the same setting with ``--safeguards``, the table's fallback."""
    if row["l0_label"] != MF_TABLE_L0 or math.isfinite(_num(row.get("branched_from_s"))):
        return False
    if _num(row.get("collision_ramp") or 0.0) != 0.0:  # a column absent: the hard threshold
        return False
    if row.get("wet_margin") not in (None, "") and _num(row["wet_margin"]) != 1:
        return False  # a column absent: the default margin
    for key, want in (MF_TABLE_SETTING | {"safeguards": safeguards}).items():
        have = row.get(key, False if isinstance(want, bool) else "")  # a switch absent: off
        if isinstance(want, bool):
            if str(have).lower() not in (str(want).lower(), "1" if want else "0"):
                return False
        elif isinstance(want, float | int):
            if not math.isclose(_num(have), float(want)):
                return False
        elif str(have) != want:
            return False
    return True


def heavy_reference(case: Case, l0_label: str) -> tuple[float, float]:
    """(raw, 11 ms mean) MF of the heavy elastic plate (the section the thesis's thickness
    gives) against the rigid plate, both from bottom_slamming_<l0_label>.csv; NaN if absent."""
    path = RESULTS_DIR / f"bottom_slamming_{l0_label}.csv"
    if not path.is_file():
        return math.nan, math.nan
    peaks = {}
    for r in read_csv(path):
        if math.isclose(float(r["a_over_h"]), case.ratio) and math.isclose(
            float(r["d_over_h"]), case.clearance
        ):
            peaks[r["kind"]] = (float(r["peak_uplift"]), float(r["peak_uplift_smooth"]))
    if "rigid" not in peaks or "elastic" not in peaks:
        return math.nan, math.nan
    (e, es), (r, rs) = peaks["elastic"], peaks["rigid"]
    return e / r, es / rs


#: the MF table's columns taken from the light CSV's row as they are, and under another name
_TABLE_COPIED = (
    "wet_from_s", "wet_it_mean", "interface_work_error_pct", "peak_uplift",
    "peak_time_s", "peak_uplift_smooth", "peak_smooth_time_s", "mid_disp_max_mm",
    "mid_disp_max_time_s", "mid_back_at_rest_s", "return_peak_smooth",
)  # fmt: skip
_TABLE_RENAMED = {
    "rigid_peak": "rigid_peak_same_l0",
    "rigid_peak_smooth": "rigid_peak_smooth_same_l0",
    "mf_raw": "mf_raw_same_l0",
    "mf_smooth": "mf_smooth_same_l0",
}


def _longest_runs(rows: list[dict], safeguards: bool) -> dict[tuple[float, float], dict]:
    """Per (A/H, D/H) the longest run of the table's setting (a shorter one is its prefix)."""
    best: dict[tuple[float, float], dict] = {}
    for r in rows:
        if not _in_table_setting(r, safeguards):
            continue
        key = (round(float(r["a_over_h"]), 3), round(float(r["d_over_h"]), 3))
        if key not in best or _num(r["t_end_s"]) > _num(best[key]["t_end_s"]):
            best[key] = r
    return best


def mf_table(rows: list[dict]) -> list[dict]:
    """The MF table's rows: per (A/H, D/H) the longest run of :data:`MF_TABLE_SETTING` at
    :data:`MF_TABLE_L0`, with MF against the rigid plate at the same spacing, the heavy plate's
    MF and the thesis's. Where that run stopped before the case's analysis window ended (or is
    absent), the same setting with ``--safeguards`` stands in if it got further (column
    ``safeguards``). Loads N/m, times s, displacements mm."""
    plain, guarded = _longest_runs(rows, False), _longest_runs(rows, True)
    best = {}
    for key in plain.keys() | guarded.keys():
        r = plain.get(key)
        if r is None or _num(r["t_end_s"]) < Case(*key).reflection_time - 1e-3:
            g = guarded.get(key)
            if g is not None and (r is None or _num(g["t_end_s"]) > _num(r["t_end_s"])):
                r = g
        best[key] = r
    out = []
    for (a, d), r in sorted(best.items()):
        case = Case(a, d)
        wet, unconv = int(_num(r["wet_windows"] or 0)), int(_num(r["wet_unconverged"] or 0))
        heavy, heavy_s = heavy_reference(case, MF_TABLE_L0)
        row = {"a_over_h": a, "d_over_h": d, "l0_label": r["l0_label"]}
        row["safeguards"] = _in_table_setting(r, True)
        row["t_end_s"] = _num(r["t_end_s"])
        row["window_end_s"] = case.reflection_time
        row["reached_window_end"] = row["t_end_s"] >= case.reflection_time - 1e-3
        row |= {"wet_windows": wet, "wet_unconverged": unconv}
        row["wet_unconverged_pct"] = 100.0 * unconv / wet if wet else math.nan
        row |= {k: _num(r[k]) for k in _TABLE_COPIED}
        row |= {k: _num(r[source]) for k, source in _TABLE_RENAMED.items()}
        row |= {"heavy_mf_raw": heavy, "heavy_mf_smooth": heavy_s}
        row["thesis_mf"] = THESIS_MF.get((a, d), math.nan)
        row["results_file"] = r["results_file"]
        out.append(row)
    return out


def plot_mf_table(table: list[dict], out: Path) -> None:
    """MF (11 ms means filled, raw peaks open) against A/H per clearance: the light plate, the
    heavy plate and the thesis, on a log axis."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    clearances = (0.03, 0.06, 0.1)
    fig, axes = plt.subplots(1, 3, figsize=(10.0, 3.6), sharey=True)
    for ax, d in zip(axes, clearances, strict=True):
        rows = [r for r in table if math.isclose(r["d_over_h"], d)]
        a = [r["a_over_h"] for r in rows]
        ax.plot(a, [r["mf_smooth"] for r in rows], "o-", color="C0", label="light, 11 ms mean")
        ax.plot(a, [r["mf_raw"] for r in rows], "o", mfc="none", color="C0", label="light, raw")
        sg = [r for r in rows if r["safeguards"]]
        ax.plot([r["a_over_h"] for r in sg], [r["mf_smooth"] for r in sg], "D", ms=9, mfc="none",
                color="C2", label="light, with --safeguards")  # fmt: skip
        short = [r for r in rows if not r["reached_window_end"]]
        ax.plot([r["a_over_h"] for r in short], [r["mf_smooth"] for r in short], "x", ms=10,
                color="C3", label="light, stopped before the window's end")  # fmt: skip
        ah = (0.2, 0.3, 0.4, 0.5)
        heavy = [heavy_reference(Case(x, d), MF_TABLE_L0) for x in ah]
        ax.plot(ah, [h[1] for h in heavy], "s-", color="C1", label="heavy, 11 ms mean")
        ax.plot(ah, [h[0] for h in heavy], "s", mfc="none", color="C1", label="heavy, raw")
        th = sorted((k[0], v) for k, v in THESIS_MF.items() if math.isclose(k[1], d))
        ax.plot([x for x, _ in th], [v for _, v in th], "^-", color="k", label="thesis")
        ax.set_yscale("log")
        ax.set_title(f"D/H = {d:g}")
        ax.set_xlabel("A/H")
        ax.grid(alpha=0.3, which="both")
    axes[0].set_ylabel("MF = F_elastic,max / F_rigid,max")
    axes[0].legend(fontsize=7)
    fig.suptitle(f"Light plate (0.026 kg/m^2) MF at l0 = {MF_TABLE_L0} m against the thesis")
    fig.tight_layout()
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=80)
    plt.close(fig)


def print_mf_table(table: list[dict]) -> None:
    """The MF table as markdown (docs/validation_bottom_slamming_light.md)."""
    print("| A/H | D/H | run to (s) | wet windows: it./window, unconverged | light MF raw "
          "(11 ms mean) | heavy MF raw (11 ms mean) | thesis MF | mid-span max (mm) |")  # fmt: skip
    print("|---|---|---|---|---|---|---|---|")
    for r in table:
        print(
            f"| {r['a_over_h']:g} | {r['d_over_h']:g}{', `--safeguards`' if r['safeguards'] else ''} "
            f"| {r['t_end_s']:.2f} | "
            f"{r['wet_it_mean']:.1f}, {r['wet_unconverged']} of {r['wet_windows']} "
            f"({r['wet_unconverged_pct']:.0f} %) | {r['mf_raw']:.3f} ({r['mf_smooth']:.3f}) | "
            f"{r['heavy_mf_raw']:.2f} ({r['heavy_mf_smooth']:.2f}) | {r['thesis_mf']:.2f} | "
            f"{r['mid_disp_max_mm']:.1f} |"
        )


#: what the plate carries at rest: uniform uplift (N/m, the total per m of width) against the
#: static mid-span deflection of the co-rotational member (issue 21, why the thesis's MF is out
#: of this section's reach)
STATIC_CSV = RESULTS_DIR / "bottom_slamming_light_static_capacity.csv"
STATIC_LOADS = (1e-4, 0.01, 0.03, 0.1, 0.3, 1.0, 3.0, 10.0, 30.0)


def static_capacity(totals: tuple[float, ...] = STATIC_LOADS) -> list[dict]:
    """Static mid-span deflection (mm, up) of the light plate (the scenario's co-rotational
    member, pinned at both ends with the axial dof, at l0 = 0.004 m's 74 elements) under a
    uniform dead uplift of each total (N/m; the line load is total / L), by load stepping and
    Newton from straight; beside it the linear beam's 5 q L^4 / (384 EI) (Timoshenko & Gere,
    simply supported beam under a uniform load) and the membrane limit (3 q L^4 / (64 EA))^(1/3)
    (a pinned string: sag w = q L^2 / (8 T), T = EA (8/3) (w / L)^2). A total whose static solve
    fails is reported with NaN."""
    from mpsfem.scenario.loader import load_scenario
    from mpsfem.structure_fem.newton import NewtonFailure
    from mpsfem.structure_fem.participant import StructureParticipant

    case = Case(0.3, 0.06)
    overrides = case_overrides("elastic", case, spacing_for(0.004, DEPTH)) + light_overrides(
        0.35, 1e-3, "displacement", 100, "0.05", None, "potential_flow", 3.0,
        kinematics="corotational",
    )  # fmt: skip
    section = load_scenario(SCENARIOS["elastic"], overrides).scenario.structure
    rows = []
    for total in totals:
        part = StructureParticipant(section, fluid_density=WATER_DENSITY)  # from straight
        system, member = part.system, part.system.models[0]
        length = float(member.length)
        q = total / length  # N/m^2 on a 1 m wide plate
        up = float(np.sign(member.normal[1]))  # the member's normal is (0, +-1)
        F = member.pressure_load(up * q)[system.free_of(member.name)]
        mid = int(np.argmin(np.abs(member.nodes[:, 0] - member.nodes[:, 0].mean())))
        segments = np.linalg.norm(np.diff(member.nodes, axis=0), axis=1)
        try:
            moved = system.nodal(part.integrator.solve_static(F, increments=16))
            w = float(moved[mid, 1])
            chords = np.linalg.norm(np.diff(member.nodes + moved, axis=0), axis=1)
            strain = float(np.max(chords / segments) - 1.0)
        except NewtonFailure:
            w = strain = math.nan
        rows.append(
            {
                "total_uplift": total,
                "mid_disp_mm": w * 1e3,
                "max_axial_strain": strain,  # chord stretch of the most stretched element
                "linear_beam_mm": 5.0 * q * length**4 / (384.0 * member.EI) * 1e3,
                "string_mm": (3.0 * q * length**4 / (64.0 * member.EA)) ** (1.0 / 3.0) * 1e3,
            }
        )
    return rows


def _row_file(row: dict[str, str]) -> str:
    """The results file name of a CSV row (rows written before the column: from its fields)."""
    if row.get("results_file"):
        return row["results_file"]
    ft = row.get("force_tolerance", "none")
    return run_path(
        row["l0_label"],
        Case(float(row["a_over_h"]), float(row["d_over_h"])),
        float(row["mf_factor"]),
        float(row["rtol"]),
        row["relative_to"],
        int(row["max_iterations"]),
        None if ft == "none" else ft,
    ).name


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--l0", default="0.004", help="particle spacing, m (default 0.004)")
    ap.add_argument("--cases", default="0.3:0.06", help="A/H:D/H pairs (default 0.3:0.06)")
    ap.add_argument("--mf", default="0.3,1", help="fictitious mass / estimate, comma-separated")
    ap.add_argument("--rtol", default="1e-3", help="coupling relative tolerance(s)")
    ap.add_argument(
        "--relative-to",
        default="displacement",
        choices=("displacement", "window_motion"),
        help="coupling.convergence.relative_to (default displacement, as the scenario)",
    )
    ap.add_argument(
        "--max-iterations", type=int, default=30, help="per window (default 30, as the scenario)"
    )
    ap.add_argument(
        "--force-tolerance",
        default=None,
        help="coupling.convergence.fictitious_force_tolerance value(s), comma-separated, or "
        '"off" (default: none given, the schema\'s default; the file name then has no _ft)',
    )
    ap.add_argument(
        "--end-time", type=float, default=None, help="run.end_time, s (default: the case's)"
    )
    ap.add_argument(
        "--branch-at",
        type=float,
        default=None,
        help="run each M_f once to this time (the first --rtol and --force-tolerance), then "
        "continue every tolerance from a copy of its checkpoint there (the convergence keys "
        "may change on a restart; needs a checkpoint at that time: output.checkpoint_interval)",
    )
    ap.add_argument(
        "--base-force-tolerance",
        default=None,
        help="the force tolerance of the --branch-at base run (default: the first "
        "--force-tolerance); its dry part takes one iteration per window whatever it is",
    )
    ap.add_argument(
        "--mf-model",
        default="lumped",
        choices=("lumped", "potential_flow"),
        help="structure.members.0.fictitious_mass_model (default lumped); potential_flow: "
        "--mf is the factor on the wetted patch's potential-flow operator",
    )
    ap.add_argument(
        "--wet-pressure",
        type=float,
        default=0.0,
        help="structure.members.0.fictitious_wet_pressure, Pa (default 0: any nonzero load)",
    )
    ap.add_argument(
        "--wet-update",
        default="window",
        choices=("window", "grow"),
        help="structure.members.0.fictitious_wet_update (default window); grow: the wet set "
        "grows inside a window when a later iterate wets more nodes (file name _grow)",
    )
    ap.add_argument(
        "--freeze-surface",
        action="store_true",
        help="fluid.surface.freeze_in_coupling_window = true (rule 'settled'; file name _frz)",
    )
    ap.add_argument(
        "--acceleration",
        default="aitken",
        choices=("aitken", "iqn-ils", "iqn-imvj"),
        help="coupling.acceleration.kind (default aitken; others: file name _acc<kind>)",
    )
    ap.add_argument(
        "--kinematics",
        default="linear",
        choices=("linear", "corotational"),
        help="the member's kinematics (default linear; corotational: file name _corot)",
    )
    ap.add_argument(
        "--safeguards",
        action="store_true",
        help="coupling.convergence.accept_unconverged = best, retreat_predictor = true, "
        f"structure.time.scheme = hht with alpha {SAFEGUARD_HHT_ALPHA} (file name _sg; CSV "
        "column safeguards)",
    )
    ap.add_argument(
        "--collision-ramp",
        type=float,
        default=0.0,
        help="fluid.collision.ramp, in [0, 1) (default 0: the hard threshold; file name "
        "_ramp<r>, CSV column collision_ramp)",
    )
    ap.add_argument(
        "--wet-margin",
        type=int,
        default=1,
        help="structure.members.0.fictitious_wet_margin, elements >= 0 (default 1, the "
        "schema's; file name _mg<k>, CSV column wet_margin)",
    )
    ap.add_argument(
        "--branch-from",
        type=Path,
        default=None,
        help="a finished results file (its checkpoint at its end): continue it under this "
        "run's keys, physics included (case_runner.physics_branch; task H3's what-ifs from "
        "the 1.85 s state); --branch-at is then not used",
    )
    ap.add_argument("--added-mass", action="store_true", help="print the estimate and stop")
    ap.add_argument(
        "--static-capacity",
        action="store_true",
        help=f"the plate's static deflection under uniform uplifts -> {STATIC_CSV.name}, and stop",
    )
    case_runner.add_run_options(ap)
    args = ap.parse_args(argv)
    if args.static_capacity:
        rows = static_capacity()
        write_csv(rows, STATIC_CSV, comment="validation/bottom_slamming_light.py "
                  "--static-capacity: uniform uplift (N/m) -> static mid-span deflection (mm)")  # fmt: skip
        for r in rows:
            print(f"{r['total_uplift']:8g} N/m: {r['mid_disp_mm']:9.4g} mm, strain "
                  f"{r['max_axial_strain']:.3g} (linear beam {r['linear_beam_mm']:.4g}, string "
                  f"{r['string_mm']:.4g})")  # fmt: skip
        return 0
    if args.added_mass:
        for h in (0.004, 0.002, 0.001):
            print(f"h = {h} m: first mode {added_mass_estimate(h):.1f} kg/m^2, "
                  f"heave {added_mass_estimate(h, mode='heave'):.1f} kg/m^2")  # fmt: skip
        for f in (0.25, 0.5, 0.75):
            print(f"wetted {f:g} L from the front edge: {added_mass_estimate(0.002, f):.1f} kg/m^2")
        k = math.pi / PLATE_LENGTH
        print(f"periodic mode rho / k coth(k H): {WATER_DENSITY / k / math.tanh(k * DEPTH):.1f}")
        print(f"plate mass rho A: {MEMBER_DENSITY * AREA:.4g} kg/m^2")
        return 0
    try:
        l0 = float(args.l0)
        factors = [float(x) for x in args.mf.split(",")]
        rtols = [float(x) for x in args.rtol.split(",")]
        fts = [None] if args.force_tolerance is None else args.force_tolerance.split(",")
        for ft in fts:
            if ft is not None and ft != "off" and not 0.0 < float(ft) < 1.0:
                raise ValueError(f"--force-tolerance {ft}: a number in (0, 1) or off")
        cases = parse_cases(args.cases)
    except ValueError as exc:
        ap.error(str(exc))
    if args.wet_margin < 0:
        ap.error(f"--wet-margin {args.wet_margin}: elements >= 0")
    if not l0 > 0.0 or any(f <= 0.0 for f in factors) or any(not 0.0 < r < 1.0 for r in rtols):
        ap.error(f"--l0 {args.l0}, --mf {args.mf}, --rtol {args.rtol}: need l0 > 0, mf > 0, "
                 "0 < rtol < 1")  # fmt: skip
    spacing = spacing_for(l0, DEPTH)
    print(f"l0 = {l0:g} m -> {spacing:.7g} m; M_f estimate {ADDED_MASS_ESTIMATE} kg/m^2")
    if not args.analyse_only:
        rel, its = args.relative_to, args.max_iterations
        branched = None if args.branch_from is None else branch_time(args.branch_from)
        for case in cases:
            for rtol in rtols:
                for ft in fts:
                    for f in factors:
                        mm = args.mf_model
                        wp, wu = args.wet_pressure, args.wet_update
                        fz, acc = args.freeze_surface, args.acceleration
                        kin, sg = args.kinematics, args.safeguards
                        ramp, mg = args.collision_ramp, args.wet_margin
                        out = run_path(
                            args.l0, case, f, rtol, rel, its, ft, args.end_time, mm, wp, wu, fz,
                            acc, kin, branched, safeguards=sg, collision_ramp=ramp, wet_margin=mg,
                        )  # fmt: skip
                        overrides = case_overrides("elastic", case, spacing) + light_overrides(
                            f,
                            rtol,
                            rel,
                            its,
                            ft,
                            args.end_time,
                            mm,
                            wp,
                            wu,
                            fz,
                            acc,
                            kin,
                            safeguards=sg,
                            collision_ramp=ramp,
                            wet_margin=mg,
                        )
                        tag = f"[light {case.label()} mf {f:g} rtol {rtol:g} ft {ft}]"
                        if args.branch_from is not None:
                            case_runner.physics_branch(
                                SCENARIOS["elastic"], args.branch_from, out, overrides,
                                args.threads, args.retry_failed, tag,
                            )  # fmt: skip
                            continue
                        if args.branch_at is not None and not out.exists():
                            ft0 = args.base_force_tolerance or fts[0]
                            at = args.branch_at
                            base = run_path(
                                args.l0, case, f, rtols[0], rel, its, ft0, at, mm, wp,
                                kinematics=kin, safeguards=sg, collision_ramp=ramp,
                                wet_margin=mg,
                            )  # fmt: skip
                            base_overrides = case_overrides(
                                "elastic", case, spacing
                            ) + light_overrides(
                                f,
                                rtols[0],
                                rel,
                                its,
                                ft0,
                                at,
                                mm,
                                wp,
                                kinematics=kin,
                                safeguards=sg,
                                collision_ramp=ramp,
                                wet_margin=mg,
                            )
                            base_overrides.append(f"output.checkpoint_interval={args.branch_at!r}")
                            case_runner.branch_case(
                                SCENARIOS["elastic"], base, base_overrides, out, overrides,
                                at, args.threads, args.retry_failed, tag,
                            )  # fmt: skip
                            continue
                        case_runner.ensure_case(
                            SCENARIOS["elastic"],
                            out,
                            overrides,
                            args.threads,
                            args.retry_failed,
                            tag,
                        )
    return report()


if __name__ == "__main__":
    sys.exit(main())
