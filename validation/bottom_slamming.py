"""2D bottom slamming of a horizontal plate by a solitary wave (thesis ch. 5.1; references.md 9).

Runs scenarios/bottom_slamming_2d.toml (rigid plate, a fixed wall box) and
scenarios/bottom_slamming_elastic_2d.toml (the plate as a coupled beam) for the thesis's 12 cases
A/H = 0.2, 0.3, 0.4, 0.5 x D/H = 0.03, 0.06, 0.1 (thesis Table 5-5) at one particle spacing, each
case an ``mpsfem run`` subprocess with ``--set`` overrides (amplitude, plate height, probe
positions, end time, spacing, element count) on NUMBA_NUM_THREADS threads (default 1), one case
after another. Then it analyses every results file and writes

* validation/results/bottom_slamming_<l0>.csv: one row per case and kind (columns:
  :data:`CSV_COLUMNS`);
* docs/figures/bottom_slamming_forces_<l0>.png (uplift histories, rigid and elastic, per case),
  docs/figures/bottom_slamming_mf_<l0>.png (peak uplift and MF = F_elastic / F_rigid against
  A/H, with the thesis's MF values), docs/figures/bottom_slamming_displacement_<l0>.png (the
  elastic plate's mid-span displacement);
* docs/validation_bottom_slamming.md (set-up, results tables, thesis comparison, wall times and
  the discussion kept in :data:`DISCUSSION`), generated from the CSV.

Definitions: :func:`analyse` and docs/validation_bottom_slamming.md.

Resumable: a case whose results file says ``status = finished`` is not run again; one left
``running`` by a hard kill, or stopped by a signal (``failed: ... received signal ...``: the run
loop then writes a checkpoint of its last good step), resumes from its checkpoint
(``mpsfem run --restart``); another ``failed`` one is reported and only rerun with
``--retry-failed`` (runs are deterministic: a rerun fails again unless something changed).

    python validation/bottom_slamming.py [--l0 0.004] [--cases 0.3:0.03,0.3:0.06|all]
                                         [--kinds rigid,elastic] [--threads 1]
                                         [--analyse-only] [--retry-failed]
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import tomllib
from dataclasses import dataclass, fields
from pathlib import Path

import h5py
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import case_runner  # noqa: E402 - validation/case_runner.py: resumable runs of one case
from results_csv import read_csv, write_csv  # noqa: E402
from wave_tank import (  # noqa: E402 - the wave tank's theory and file helpers
    SolitaryWave,
    predicted_crest_time,
    read_status,
    running_mean,
    spacing_for,
)

from mpsfem.results.checkpoint import default_checkpoint_path  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
SCENARIOS = {
    "rigid": ROOT / "scenarios" / "bottom_slamming_2d.toml",
    "elastic": ROOT / "scenarios" / "bottom_slamming_elastic_2d.toml",
}
KINDS = ("rigid", "elastic")
RESULTS_DIR = ROOT / "validation" / "results"
FIGURES_DIR = ROOT / "docs" / "figures"
DOC = ROOT / "docs" / "validation_bottom_slamming.md"

DEPTH = 0.114  # H, m (thesis ch. 5.1)
GRAVITY = 9.81  # m/s^2
DENSITY = 1000.0  # kg/m^3
RATIOS = (0.2, 0.3, 0.4, 0.5)  # A/H (thesis Table 5-5)
CLEARANCES = (0.03, 0.06, 0.1)  # D/H (thesis Table 5-5)
PLATE_FRONT = 1.2  # m from the paddle's face at rest (thesis ch. 5.1)
PLATE_LENGTH = 0.305  # m (thesis ch. 5.1)
PLATE_THICKNESS = 0.015  # m (thesis ch. 5.1)
PADDLE_WALL = 1  # index of the paddle in fluid.walls (both scenarios)
PLATE_WALL = 2  # index of the rigid plate in fluid.walls (rigid scenario)
PADDLE_START = 0.2  # s, the scenarios' paddle start_time
AFTER_CREST = 0.6  # rigid runs end at the crest's arrival at the front edge + this, s
#: k |x - c t| of the wave's foot used for the reflection timing: eta = A sech^2 = 10 % of A.
#: The sponge's inner part sends back at most about half of what reaches it (38-52 % of A,
#: docs/validation_wave_tank.md), so less than 5 % of A comes back to the plate in the window.
FOOT = math.acosh(math.sqrt(10.0))
PRESSURE_PROBES = {"p_front": 1.0 / 6.0, "p_mid": 0.5, "p_rear": 5.0 / 6.0}  # x / plate length
GAUGES = (0.6, 1.0, 1.15)  # m (scenarios)
SMOOTH_S = 0.011  # running mean of the force for the smoothed peak, s (11 samples at 1 ms)

#: thesis ch. 5.1.3: MF = F_flexible,max / F_rigid,max, keyed by (A/H, D/H); A/H = 0.4 is given
#: only as a figure (Fig. 5-13; the text says MF falls from 0.3 to 0.4 for D/H = 0.03 and 0.06)
THESIS_MF = {
    (0.2, 0.03): 1.24,
    (0.2, 0.06): 1.87,
    (0.2, 0.1): 1.35,
    (0.3, 0.03): 3.23,
    (0.3, 0.06): 5.28,
    (0.3, 0.1): 3.66,
    (0.5, 0.03): 4.31,
    (0.5, 0.06): 6.35,
    (0.5, 0.1): 5.89,
}
#: thesis ch. 5.1.2-5.1.3, A/H = 0.3, D/H = 0.1: first contact (Fig. 5-7), rigid peak when the
#: crest reaches the front edge (Figs. 5-6, 5-7), the elastic plate's "second slam" (Fig. 5-11), s
THESIS_TIMES = {"contact": 1.76, "rigid_peak": 1.96, "second_slam": 2.12}
#: thesis Table 5-1: spacing (m), element length (m), fluid particles, elements
THESIS_TABLE_5_1 = ((0.0015, 0.0015, 133474, 203), (0.002, 0.002, 76078, 152),
                    (0.0025, 0.0025, 43136, 122))  # fmt: skip


# ---------------------------------------------------------------------- cases
@dataclass(frozen=True)
class Case:
    """One thesis case: wave amplitude A/H and clearance D/H of the plate's bottom above H."""

    ratio: float
    clearance: float

    @property
    def wave(self) -> SolitaryWave:
        return SolitaryWave(self.ratio * DEPTH, DEPTH, GRAVITY)

    @property
    def bottom(self) -> float:
        """Height of the plate's bottom face, H + D (m)."""
        return DEPTH * (1.0 + self.clearance)

    @property
    def crest_time(self) -> float:
        """When the design crest reaches the plate's front edge (s), paddle timing of
        wave_tank.predicted_crest_time."""
        return predicted_crest_time(self.wave, PADDLE_START, PLATE_FRONT)

    def end_time(self, kind: str) -> float:
        """Simulated end time (s): rigid, the crest's arrival at the front edge + 0.6 s (the
        rigid plate's uplift is over by then); elastic, the end of the peak window rounded up to
        10 ms (the plate swings back down onto the water about half a second after the crest)."""
        if kind == "rigid":
            return round(self.crest_time + AFTER_CREST, 3)
        return math.ceil(self.reflection_time * 100.0) / 100.0

    @property
    def reflection_time(self) -> float:
        """When the foot (eta = 10 % of A, 1.82/k ahead of the crest: :data:`FOOT`) of the
        incident wave, sent back by the sponge's inner edge (x_s = 2.0 m) at c0 = sqrt(g H),
        reaches the plate's rear edge (s): the end of the window in which the peaks are taken."""
        w = self.wave
        c, c0 = w.c_first_order, math.sqrt(GRAVITY * DEPTH)
        x_s, rear = 2.0, PLATE_FRONT + PLATE_LENGTH
        return self.crest_time + (x_s - FOOT / w.k - PLATE_FRONT) / c + (x_s - rear) / c0

    def label(self) -> str:
        return f"AH{self.ratio:.2f}_DH{self.clearance:.2f}"


def hydrostatic_uplift(case: Case, crest_x: float) -> float:
    """Quasi-static uplift (N/m) with the crest of the undisturbed first-order wave at x:
    rho g integral over the plate of max(eta(x') - D, 0) dx', the hydrostatic head of the water
    the plate keeps below its bottom (long-wave estimate: the 0.305 m plate is short against
    the wave, 2 x 3.8 / k = 1.5-2.2 m)."""
    w = case.wave
    x = np.linspace(PLATE_FRONT, PLATE_FRONT + PLATE_LENGTH, 2001)
    eta = w.amplitude / np.cosh(w.k * (x - crest_x)) ** 2
    head = np.maximum(eta - case.clearance * DEPTH, 0.0)
    return float(DENSITY * GRAVITY * np.sum(0.5 * (head[1:] + head[:-1]) * np.diff(x)))


def uplift_bounds(case: Case) -> tuple[float, float]:
    """(lower, upper) physical bounds of the rigid plate's peak uplift (N/m), used by the tests.

    lower: the quasi-static uplift with the crest at the front edge (the instant the thesis's
    rigid peak occurs, Figs. 5-6, 5-7; the bottom is wet all along by then);
    upper: the largest quasi-static uplift over all crest positions plus a slamming part
    rho U w L: the wetted length grows at the wave speed U = c while the surface below meets the
    plate at most at the first-order wave's largest rise speed w = c A k 4 / (3 sqrt 3)
    (max of c d(eta)/dx), a Wagner-type pressure rho U w over the whole length L."""
    xs = np.linspace(PLATE_FRONT - 0.5, PLATE_FRONT + PLATE_LENGTH + 0.5, 201)
    quasi_max = max(hydrostatic_uplift(case, x) for x in xs)
    return hydrostatic_uplift(case, PLATE_FRONT), quasi_max + _slam_scale(case)


def _slam_scale(case: Case) -> float:
    w = case.wave
    rise = w.c_first_order * w.amplitude * w.k * 4.0 / (3.0 * math.sqrt(3.0))
    return DENSITY * w.c_first_order * rise * PLATE_LENGTH


def all_cases() -> list[Case]:
    """The thesis's 12 cases, A/H = 0.3 first (the thesis's MF row), then the others."""
    order = (0.3, 0.2, 0.4, 0.5)
    return [Case(r, d) for r in order for d in CLEARANCES]


def parse_cases(text: str) -> list[Case]:
    """``all`` or comma-separated ``A/H:D/H`` pairs; ``A/H:*`` means every D/H."""
    if text.strip() == "all":
        return all_cases()
    out: list[Case] = []
    for item in text.split(","):
        try:
            r_text, d_text = item.split(":")
            r = float(r_text)
            ds = CLEARANCES if d_text.strip() == "*" else (float(d_text),)
        except ValueError as exc:
            raise ValueError(f"--cases item {item!r}: expected A/H:D/H, e.g. 0.3:0.06") from exc
        if not 0.0 < r < 0.78:
            raise ValueError(f"--cases {item!r}: A/H = {r} must lie in (0, 0.78)")
        for d in ds:
            if not 0.0 < d < 1.0:
                raise ValueError(f"--cases {item!r}: D/H = {d} must lie in (0, 1)")
            out.append(Case(r, d))
    return out


def elements_for(spacing: float) -> int:
    """Beam elements: the largest count whose element length is >= the particle spacing
    (the transpose mappings load the nodes unevenly below it, docs/coupler.md)."""
    return max(1, math.floor(PLATE_LENGTH / spacing * (1.0 + 1e-9)))


def probe_index(kind: str) -> dict[str, int]:
    """Index of every probe in the kind's scenario, by name."""
    with SCENARIOS[kind].open("rb") as f:
        probes = tomllib.load(f)["probes"]
    return {p["name"]: i for i, p in enumerate(probes)}


def case_overrides(kind: str, case: Case, spacing: float) -> list[str]:
    """The ``--set`` overrides that turn the kind's scenario into ``case`` at ``spacing``."""
    y0 = case.bottom
    idx = probe_index(kind)
    items = [
        f"fluid.spacing={spacing!r}",
        f"fluid.walls.{PADDLE_WALL}.motion.amplitude={case.wave.amplitude!r}",
        f"fluid.walls.{PADDLE_WALL}.motion.depth={DEPTH!r}",
        f"run.end_time={case.end_time(kind)!r}",
        f'title="bottom slamming ({kind}), A/H = {case.ratio:g}, D/H = {case.clearance:g}, '
        f'l0 = {spacing:.6g} m"',
    ]
    for name, frac in PRESSURE_PROBES.items():
        x = PLATE_FRONT + frac * PLATE_LENGTH
        items.append(f"probes.{idx[name]}.position=[{x!r}, {y0!r}]")
    if kind == "rigid":
        items += [
            f"fluid.walls.{PLATE_WALL}.lower=[{PLATE_FRONT!r}, {y0!r}]",
            f"fluid.walls.{PLATE_WALL}.upper=[{PLATE_FRONT + PLATE_LENGTH!r}, "
            f"{y0 + PLATE_THICKNESS!r}]",
        ]
    else:
        yc = y0 + 0.5 * PLATE_THICKNESS
        items += [
            f"structure.members.0.start=[{PLATE_FRONT!r}, {yc!r}]",
            f"structure.members.0.end=[{PLATE_FRONT + PLATE_LENGTH!r}, {yc!r}]",
            f"structure.members.0.elements={elements_for(spacing)}",
            f"probes.{idx['plate_mid']}.position=[{PLATE_FRONT + 0.5 * PLATE_LENGTH!r}, {yc!r}]",
        ]
    return items


def case_path(l0_label: str, kind: str, case: Case) -> Path:
    return RESULTS_DIR / f"bottom_slamming_{l0_label}_{kind}_{case.label()}.h5"


# ---------------------------------------------------------------------- running
def run_case(
    kind: str, case: Case, spacing: float, out: Path, threads: int, restart: Path | None
) -> int:
    """``mpsfem run`` of one case in a subprocess on ``threads`` numba threads; its exit code."""
    overrides = case_overrides(kind, case, spacing)
    tag = f"[{kind} {case.label()}]"
    return case_runner.run_scenario(SCENARIOS[kind], out, overrides, threads, restart, tag)


def recorded_until(path: Path) -> float:
    """Time (s) of the last uplift sample of a results file."""
    with h5py.File(path, "r") as h5:
        t = h5["probes"]["uplift"]["time"]
        return float(t[-1]) if t.shape[0] else 0.0


#: status texts of a run stopped by SIGTERM / Ctrl-C: the run loop's own message, and what it
#: says when the signal arrived inside a numba function (the handler's exception then surfaces
#: as "CPUDispatcher(...) returned a result with an exception set"); both leave a checkpoint of
#: the last good step
def ensure_case(kind: str, case: Case, spacing: float, out: Path, threads: int, retry: bool) -> str:
    """Run (or resume) one case unless its results file says finished (``case_runner``), and
    extend a finished one whose end time is now later; its final status."""
    tag = f"[{kind} {case.label()}]"
    status = read_status(out)
    ckpt = default_checkpoint_path(out)
    end = case.end_time(kind)
    # the last probe sample may lie up to one probe interval (1 ms) before the end
    if status == "finished" and recorded_until(out) < end - 2e-3 and ckpt.is_file():
        # finished with an earlier end time: continue from its final checkpoint
        print(
            f"{tag} {out.name}: finished at {recorded_until(out):.4g} s, extending to {end:.4g} s"
        )
        run_case(kind, case, spacing, out, threads, ckpt)
        return read_status(out) or "missing"
    overrides = case_overrides(kind, case, spacing)
    return case_runner.ensure_case(SCENARIOS[kind], out, overrides, threads, retry, tag)


# ---------------------------------------------------------------------- analysis
@dataclass
class CaseResult:
    """One row of validation/results/bottom_slamming_<l0>.csv (forces N/m, times s, m)."""

    kind: str
    a_over_h: float
    d_over_h: float
    l0: float
    status: str
    fluid_particles: int
    particles: int
    elements: int  # beam elements (0 for the rigid plate)
    t_end_s: float  # simulated so far
    crest_time_s: float  # design crest at the plate's front edge
    window_end_s: float  # peaks are taken before this (reflection timing)
    contact_time_s: float  # uplift first above 2 % of its peak
    peak_uplift: float  # max of the uplift samples in the window, N/m
    peak_time_s: float
    peak_uplift_smooth: float  # max of the 11 ms running mean, N/m
    peak_smooth_time_s: float
    uplift_impulse: float  # integral of the uplift from contact to the window end, N s/m
    peak_over_rho_g_a_l: float  # peak_uplift / (rho g A L)
    quasi_static_max: float  # largest hydrostatic_uplift over crest positions, N/m
    first_peak: float  # elastic: the largest uplift before the plate's first upward peak
    min_uplift: float  # most negative uplift in the window (green water on top), N/m
    peak_horizontal: float  # max |fx| in the window, N/m
    mid_disp_max_mm: float  # elastic: largest upward mid-span displacement
    mid_disp_min_mm: float  # elastic: largest downward mid-span displacement
    mid_disp_max_time_s: float
    windows: int  # elastic: coupling windows
    iterations: int  # elastic: coupling iterations in all
    unconverged_windows: int  # elastic: accepted with on_divergence = "continue"
    interface_work_error_pct: float  # elastic: max |interface work error| / max structure energy
    steps: int  # fluid steps
    wall_time_s: float


CSV_COLUMNS = tuple(f.name for f in fields(CaseResult))


def _series(h5: h5py.File, name: str) -> tuple[np.ndarray, np.ndarray]:
    g = h5["probes"][name]
    return g["time"][:], g["value"][:]


def uplift_impulse(t: np.ndarray, fy: np.ndarray, contact: float, window_end: float) -> float:
    """Integral of the uplift (N/m) over contact <= t <= window_end by the trapezoidal rule,
    N s/m; NaN without contact or with fewer than two samples there."""
    if not math.isfinite(contact):
        return math.nan
    wet = (t >= contact) & (t <= window_end)
    return float(np.trapezoid(fy[wet], t[wet])) if np.count_nonzero(wet) > 1 else math.nan


def smooth_force(t: np.ndarray, f: np.ndarray) -> np.ndarray:
    """Centred running mean of a force record f(t) over SMOOTH_S (N/m), the n = 2 round(SMOOTH_S
    / 2 dt) + 1 samples at its median spacing dt (1 ms if there is one sample); NaN within half
    the width of either end."""
    dt = float(np.median(np.diff(t))) if t.size > 1 else 1e-3
    return running_mean(f, 2 * max(1, int(round(0.5 * SMOOTH_S / dt))) + 1)


def analyse(path: Path) -> CaseResult:
    """Every measurement of one results file.

    * uplift = the y component of the fluid's pressure force on the plate (probe "uplift", N
      per metre of width; both faces for the elastic member). The peak is the largest sample
      (every 1 ms) from the start to the window end :attr:`Case.reflection_time` (or the end of
      the record); "smooth" the largest value of its 11 ms centred running mean (MPS pressure
      spikes last one or two steps).
    * contact: the first sample above 2 % of the peak.
    * first_peak (elastic): the largest uplift up to the time of the plate's first upward
      displacement maximum (the thesis's "first slam"; after it the plate comes down on the
      water: the "second slam"); NaN for the rigid plate.
    """
    with h5py.File(path, "r") as h5:
        resolved = json.loads(h5.attrs["scenario_resolved"])
        fluid = resolved["fluid"]
        amp = fluid["walls"][PADDLE_WALL]["motion"]["amplitude"]
        elastic = resolved.get("structure") is not None
        if elastic:
            member = resolved["structure"]["members"][0]
            bottom = member["start"][1] - 0.5 * PLATE_THICKNESS
            elements = int(member["elements"])
        else:
            bottom = fluid["walls"][PLATE_WALL]["lower"][1]
            elements = 0
        case = Case(round(amp / DEPTH, 6), round(bottom / DEPTH - 1.0, 6))
        status = str(h5.attrs.get("status", "unknown"))
        steps = int(h5.attrs.get("steps", 0))
        wall = float(h5.attrs.get("wall_time", math.nan))
        t, f = _series(h5, "uplift")
        snaps = h5["particles"]
        if len(snaps):
            kinds = snaps[next(iter(snaps))]["kind"][:]
            n_fluid, n_all = int(np.count_nonzero(kinds == 0)), int(kinds.size)
        else:
            n_fluid, n_all = -1, int(h5.attrs.get("particles", -1))
        disp = _series(h5, "plate_mid") if elastic else None
        if elastic and "coupling" in h5:
            c = h5["coupling"]
            windows = int(c["iterations"].shape[0])
            iterations = int(np.sum(c["iterations"][:]))
            unconverged = int(np.count_nonzero(c["converged"][:] == 0))
            e_max = float(np.max(c["structure_energy"][:]))
            iwe_max = float(np.max(np.abs(c["interface_work_error"][:])))
            iwe = 100.0 * iwe_max / e_max if e_max > 0.0 else math.nan
        else:
            windows = iterations = unconverged = 0
            iwe = math.nan
    fy, fx = f[:, 1], f[:, 0]
    w_end = case.reflection_time
    sel = t <= w_end
    if not sel.any():
        raise ValueError(f"{path.name}: no uplift samples before {w_end:.3f} s")
    i = int(np.argmax(np.where(sel, fy, -np.inf)))
    peak, t_peak = float(fy[i]), float(t[i])
    smooth = smooth_force(t, fy)
    js = int(np.nanargmax(np.where(sel, smooth, np.nan)))
    peak_smooth, t_peak_smooth = float(smooth[js]), float(t[js])
    above = np.flatnonzero(sel & (fy > 0.02 * peak))
    contact = float(t[above[0]]) if above.size and peak > 0 else math.nan
    impulse = uplift_impulse(t, fy, contact, w_end)
    first_peak = math.nan
    d_max = d_min = t_dmax = math.nan
    if disp is not None:
        td, u = disp
        uy = u[:, 1]
        dsel = td <= w_end
        if dsel.any():
            j = int(np.argmax(np.where(dsel, uy, -np.inf)))
            d_max, t_dmax = float(uy[j]) * 1e3, float(td[j])
            d_min = float(np.min(uy[dsel])) * 1e3
            # first upward maximum of the mid-span: first local max above half the largest
            k = np.flatnonzero(dsel[1:-1] & (uy[1:-1] >= uy[:-2]) & (uy[1:-1] > uy[2:])
                               & (uy[1:-1] > 0.5 * uy[j])) + 1  # fmt: skip
            t_first = float(td[k[0]]) if k.size else t_dmax
            first = sel & (t <= t_first)
            if first.any():
                first_peak = float(np.max(fy[first]))
    return CaseResult(
        kind="elastic" if elastic else "rigid",
        a_over_h=case.ratio,
        d_over_h=case.clearance,
        l0=fluid["spacing"],
        status=status,
        fluid_particles=n_fluid,
        particles=n_all,
        elements=elements,
        t_end_s=float(t[-1]) if t.size else 0.0,
        crest_time_s=case.crest_time,
        window_end_s=w_end,
        contact_time_s=contact,
        peak_uplift=peak,
        peak_time_s=t_peak,
        peak_uplift_smooth=peak_smooth,
        peak_smooth_time_s=t_peak_smooth,
        uplift_impulse=impulse,
        peak_over_rho_g_a_l=peak / (DENSITY * GRAVITY * amp * PLATE_LENGTH),
        quasi_static_max=uplift_bounds(case)[1] - _slam_scale(case),
        first_peak=first_peak,
        min_uplift=float(np.min(fy[sel])),
        peak_horizontal=float(np.max(np.abs(fx[sel]))),
        mid_disp_max_mm=d_max,
        mid_disp_min_mm=d_min,
        mid_disp_max_time_s=t_dmax,
        windows=windows,
        iterations=iterations,
        unconverged_windows=unconverged,
        interface_work_error_pct=iwe,
        steps=steps,
        wall_time_s=wall,
    )


def magnification(rows: list[CaseResult]) -> dict[tuple[float, float], tuple[float, float]]:
    """MF = F_elastic,max / F_rigid,max per (A/H, D/H): (raw peaks, smoothed peaks)."""
    by = {(r.kind, r.a_over_h, r.d_over_h): r for r in rows}
    out = {}
    for (kind, a, d), r in by.items():
        rigid = by.get(("rigid", a, d))
        if kind == "elastic" and rigid is not None and rigid.peak_uplift > 0:
            out[(a, d)] = (
                r.peak_uplift / rigid.peak_uplift,
                r.peak_uplift_smooth / rigid.peak_uplift_smooth,
            )
    return out


# ---------------------------------------------------------------------- report
def collect(l0_label: str) -> list[CaseResult]:
    """Analyse every results file of this spacing that can be read (finished or not)."""
    rows = []
    for kind in KINDS:
        for case in all_cases():
            path = case_path(l0_label, kind, case)
            status = read_status(path)
            if not case_runner.analysable(status):
                continue
            try:
                rows.append(analyse(path))
            except (KeyError, ValueError) as exc:
                print(f"[{kind} {case.label()}] {path.name}: cannot analyse ({exc})")
    return rows


def report(l0_label: str) -> int:
    """CSV, figures, doc and a printed table of every case of this spacing."""
    rows = collect(l0_label)
    if not rows:
        print("nothing to analyse")
        return 1
    csv_path = RESULTS_DIR / f"bottom_slamming_{l0_label}.csv"
    write_csv(rows, csv_path, CSV_COLUMNS)
    plot_forces(l0_label, rows, FIGURES_DIR / f"bottom_slamming_forces_{l0_label}.png")
    plot_mf(l0_label, rows, FIGURES_DIR / f"bottom_slamming_mf_{l0_label}.png")
    plot_displacement(l0_label, rows, FIGURES_DIR / f"bottom_slamming_displacement_{l0_label}.png")
    print_table(rows)
    write_doc(l0_label, csv_path, DOC)
    print(f"wrote {_rel(csv_path)}, {_rel(DOC)} and docs/figures/bottom_slamming_*_{l0_label}.png")
    return 0 if all(r.status == "finished" for r in rows) else 1


def print_table(rows: list[CaseResult]) -> None:
    mf = magnification(rows)
    print(
        f"{'kind':>7} {'A/H':>4} {'D/H':>5} {'status':>9} {'t_end':>6} {'peak':>8} {'t_peak':>7} "
        f"{'smooth':>8} {'F/rgAL':>7} {'MF':>6} {'thesis':>6} {'steps':>6} {'wall s':>7}"
    )
    for r in sorted(rows, key=lambda r: (r.a_over_h, r.d_over_h, r.kind)):
        m = (
            mf.get((r.a_over_h, r.d_over_h), (math.nan, math.nan))[0]
            if r.kind == "elastic"
            else math.nan
        )
        th = THESIS_MF.get((r.a_over_h, r.d_over_h), math.nan) if r.kind == "elastic" else math.nan
        print(
            f"{r.kind:>7} {r.a_over_h:>4g} {r.d_over_h:>5g} {r.status[:9]:>9} {r.t_end_s:>6.3f} "
            f"{r.peak_uplift:>8.2f} {r.peak_time_s:>7.3f} {r.peak_uplift_smooth:>8.2f} "
            f"{r.peak_over_rho_g_a_l:>7.3f} {m:>6.2f} {th:>6.2f} {r.steps:>6d} {r.wall_time_s:>7.0f}"
        )


# ---------------------------------------------------------------------- figures
def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def plot_forces(l0_label: str, rows: list[CaseResult], out: Path) -> None:
    """Uplift histories against t - t_c (t_c: design crest at the front edge), one panel per
    case (rows D/H, columns A/H), rigid and elastic overlaid: every sample (light) and the
    11 ms running mean (solid); the window end dotted."""
    plt = _pyplot()
    ratios = sorted({r.a_over_h for r in rows})
    clears = sorted({r.d_over_h for r in rows})
    fig, axes = plt.subplots(
        len(clears), len(ratios), figsize=(3.0 * len(ratios), 2.3 * len(clears)), squeeze=False
    )
    for i, d in enumerate(clears):
        for j, a in enumerate(ratios):
            ax = axes[i][j]
            case = Case(a, d)
            for kind, color in (("rigid", "k"), ("elastic", "C3")):
                path = case_path(l0_label, kind, case)
                if not any(r.kind == kind and (r.a_over_h, r.d_over_h) == (a, d) for r in rows):
                    continue
                with h5py.File(path, "r") as h5:
                    t, f = _series(h5, "uplift")
                ax.plot(t - case.crest_time, f[:, 1], color=color, lw=0.4, alpha=0.3)
                ax.plot(t - case.crest_time, smooth_force(t, f[:, 1]), color=color, lw=1.0,
                        label=f"{kind} (11 ms mean)")  # fmt: skip
            ax.axvline(case.reflection_time - case.crest_time, color="0.5", ls=":", lw=0.8)
            ax.axhline(0.0, color="0.6", lw=0.4)
            ax.set_xlim(-0.4, 0.85)
            ax.set_title(f"A/H = {a:g}, D/H = {d:g}", fontsize=8)
            ax.tick_params(labelsize=7)
            ax.grid(alpha=0.3)
            if j == 0:
                ax.set_ylabel("uplift (N/m)", fontsize=8)
            if i == len(clears) - 1:
                ax.set_xlabel("t - t_c (s)", fontsize=8)
    axes[0][0].legend(fontsize=7)
    fig.suptitle(f"Uplift force, l0 = {l0_label} m", fontsize=9)
    fig.tight_layout()
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=80)
    plt.close(fig)


def plot_displacement(l0_label: str, rows: list[CaseResult], out: Path) -> None:
    """The elastic plate's mid-span vertical displacement against t - t_c, every case."""
    plt = _pyplot()
    el = sorted((r for r in rows if r.kind == "elastic"), key=lambda r: (r.a_over_h, r.d_over_h))
    if not el:
        return
    fig, ax = plt.subplots(figsize=(7.0, 3.2))
    for n, r in enumerate(el):
        case = Case(r.a_over_h, r.d_over_h)
        with h5py.File(case_path(l0_label, "elastic", case), "r") as h5:
            t, u = _series(h5, "plate_mid")
        ax.plot(t - case.crest_time, u[:, 1] * 1e3, lw=0.8, color=f"C{n}",
                label=f"A/H = {r.a_over_h:g}, D/H = {r.d_over_h:g}")  # fmt: skip
    ax.axhline(0.0, color="0.6", lw=0.4)
    ax.set_xlim(-0.4, 0.85)
    ax.set_xlabel("t - t_c (s)", fontsize=8)
    ax.set_ylabel("mid-span displacement (mm)", fontsize=8)
    ax.tick_params(labelsize=7)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7)
    ax.set_title(f"Elastic plate, mid-span (up +), l0 = {l0_label} m", fontsize=9)
    fig.tight_layout()
    fig.savefig(out, dpi=80)
    plt.close(fig)


def plot_mf(l0_label: str, rows: list[CaseResult], out: Path) -> None:
    """Left: peak uplift against A/H per D/H (rigid filled, elastic open; lines the 11 ms-mean
    peaks, faint markers the raw ones). Right: MF against
    A/H per D/H, ours (raw peaks: circles; 11 ms means: triangles) and the thesis's (crosses)."""
    plt = _pyplot()
    mf = magnification(rows)
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(9.0, 3.4))
    for n, d in enumerate(CLEARANCES):
        col = f"C{n}"
        for kind, mk, fill in (("rigid", "o", col), ("elastic", "s", "none")):
            sel = sorted((r.a_over_h, r.peak_uplift, r.peak_uplift_smooth) for r in rows
                         if r.kind == kind and r.d_over_h == d)  # fmt: skip
            if sel:
                a, f, fs = zip(*sel, strict=True)
                ax1.plot(a, fs, marker=mk, color=col, mfc=fill, lw=0.8,
                         label=f"{kind}, D/H = {d:g}")  # fmt: skip
                ax1.plot(a, f, marker=mk, color=col, mfc=fill, lw=0, alpha=0.35, ms=4)
        ours = sorted((a, v[0], v[1]) for (a, dd), v in mf.items() if dd == d)
        if ours:
            a, raw, sm = zip(*ours, strict=True)
            ax2.plot(a, raw, "o-", color=col, lw=0.8, label=f"ours, D/H = {d:g}")
            ax2.plot(a, sm, "^", color=col, mfc="none", ms=5)
        th = sorted((a, v) for (a, dd), v in THESIS_MF.items() if dd == d)
        a, v = zip(*th, strict=True)
        ax2.plot(a, v, "x--", color=col, lw=0.6, label=f"thesis, D/H = {d:g}")
    ax2.axhline(1.0, color="0.5", lw=0.5)
    ax1.set_xlabel("A/H", fontsize=8)
    ax1.set_ylabel("peak uplift (N/m): 11 ms mean (lines), raw (faint)", fontsize=8)
    ax2.set_xlabel("A/H", fontsize=8)
    ax2.set_ylabel("MF = F_elastic,max / F_rigid,max", fontsize=8)
    for ax in (ax1, ax2):
        ax.tick_params(labelsize=7)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=6)
    fig.suptitle(f"Peak uplift and magnification factor, l0 = {l0_label} m", fontsize=9)
    fig.tight_layout()
    fig.savefig(out, dpi=80)
    plt.close(fig)


# ---------------------------------------------------------------------- doc
def _rel(path: Path) -> str:
    try:
        return str(path.relative_to(ROOT))
    except ValueError:
        return str(path)


def _f(value: str, fmt: str) -> str:
    """Format a CSV cell; '-' for NaN or missing."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        return "-"
    return "-" if not math.isfinite(v) else format(v, fmt)


SETUP = (
    ("tank", "2.5 m from the paddle's face at rest to the end wall, 0.3 m high; sponge "
     "x = 2.0 ... 2.5 m, alpha_s = 50 1/s (eq. 3-9)", "thesis ch. 5.1 (Fig. 5-1), ch. 3.3; "
     "height ours"),
    ("water", "H = 0.114 m, rho = 1000 kg/m^3, nu = 1e-6 m^2/s, g = 9.81 m/s^2",
     "thesis Tables 5-2, 5-4"),
    ("waves", "A/H = 0.2, 0.3, 0.4, 0.5 from a Goring piston paddle (a 0.06 m box) at rest "
     "until t = 0.2 s", "A/H: thesis Table 5-5; paddle law thesis eqs. 3-4 to 3-8; box and start "
     "ours (scenarios/solitary_wave_2d.toml)"),
    ("plate", "0.305 m long, 0.015 m thick, front edge at x = 1.2 m, bottom at H + D, "
     "D/H = 0.03, 0.06, 0.1", "thesis ch. 5.1, Table 5-5"),
    ("rigid plate", "a fixed 'box' wall: 75 x 4 particles, the fluid sees 0.3054 m x 0.0163 m",
     "fixed: ours (the thesis does not say how its rigid plate is held)"),
    ("elastic plate", "Euler-Bernoulli beam per unit width, E = 1 MPa, rho = 1040 kg/m^3, "
     "A = b t, I = b t^3/12, simply supported at both ends, Rayleigh a1 = 1.665 1/s, "
     "a2 = 0.00096 s, no self-weight (f_1 = 2.27 Hz dry, zeta_1 = 6.5 %)",
     "thesis Tables 5-3, 5-7; section, supports, a2 reading and no self-weight ours "
     "(scenarios/structure_bottom_slamming_2d.toml)"),
    ("elements", "floor(0.305 m / l0): 74 of 4.12 mm at l0 = H/28", "ours (thesis: element "
     "length = l0, 152 at 0.002 m)"),
    ("coupling", "implicit, IQN-ILS, shape-function mapping, window = structure dt = 1 ms, "
     "relative tolerance 1e-3, unconverged wet/dry windows accepted", "ours "
     "(as scenarios/dam_break_elastic_obstacle_2d.toml)"),
    ("spacing", "l0 = H/28 = 0.00407 m (the thesis: 0.002 m)", "ours: the issue's parameter "
     "grid at 0.004 m, rounded to whole layers over H"),
    ("time step", "Courant 0.2, dt_max = 1 ms", "ours"),
    ("run", "rigid until t_c + 0.6 s, elastic until the end of the peak window (t_c + 0.70 "
     "... 0.82 s), t_c the design crest's arrival at the front edge (1.95 s at A/H = 0.3)",
     "ours (scenario header: timing)"),
)  # fmt: skip


def write_doc(l0_label: str, csv_path: Path, out: Path) -> None:
    """docs/validation_bottom_slamming.md from the CSV (and DISCUSSION)."""
    rows = read_csv(csv_path)
    by = {(r["kind"], float(r["a_over_h"]), float(r["d_over_h"])): r for r in rows}
    order = sorted(by, key=lambda k: (k[1], k[2], k[0]))
    L = []
    L.append("# Validation: 2D bottom slamming of a horizontal plate (issue 5, thesis ch. 5.1)\n")
    L.append(
        "Generated by `validation/bottom_slamming.py` from "
        f"`{_rel(csv_path)}`; do not edit by hand (the discussion is the script's "
        "`DISCUSSION`). Scenarios `scenarios/bottom_slamming_2d.toml` (rigid plate) and "
        "`scenarios/bottom_slamming_elastic_2d.toml` (elastic plate, coupled beam), tests "
        "`tests/scenarios/test_bottom_slamming.py`. The wave tank is the one validated in "
        "[validation_wave_tank.md](validation_wave_tank.md); sources: thesis ch. 5.1 "
        "(`../shared/seeds/thesis_mps_fem_solitary_wave_slamming.txt`), "
        "`../shared/references.md` section 9.\n"
    )
    L.append(
        "The elastic runs were made before the coupler's IQN-ILS kept the accepted iteration's "
        "column (commit 3d53c0d, as preCICE's `iterationsConverged`); their iteration counts are "
        "from that code. The change lowers IQN-ILS's iterations per window (1.90 to 1.82 on the "
        "hydrostatic plate at l0 = 0.05 m; 2.53 to 2.09 on the mock at mass ratio 3) and moves each "
        "window's converged state within the coupling tolerance; not re-run (hours of runs).\n"
    )
    L.append(
        "Every run below was also made before the fluid's wall boxes lined up with the fluid "
        'lattice at their wetted face (commit 801485d; docs/fluid.md, "Particles from the '
        "scenario's boxes\"): the 0.06 m paddle's pressure layer sat 0.737 l0 from the first fluid "
        "particle at t = 0, inside the collision distance (now a whole spacing: the paddle's face "
        "moved 1.07 mm), and the end wall 0.93 mm further out; the plate is where it was. Not "
        "re-run (hours of runs); the CI tests run the new layout.\n"
    )
    L.append("## Set-up\n")
    L.append("| | value | source |")
    L.append("|---|---|---|")
    for name, value, source in SETUP:
        L.append(f"| {name} | {value} | {source} |")
    L.append("")
    L.append(DEFINITIONS)
    # ---- rigid
    L.append(f"## Results at l0 = {l0_label} m\n")
    rig = [by[k] for k in order if k[0] == "rigid"]
    ela = [by[k] for k in order if k[0] == "elastic"]
    if rig:
        L.append("### Rigid plate\n")
        L.append("| A/H | D/H | status | peak uplift (N/m) | 11 ms mean peak | peak / (rho g A L) "
                 "| t_peak - t_c (s): raw, mean | contact - t_c (s) | most negative (N/m) "
                 "| max abs(F_x) (N/m) | bounds of the mean peak (N/m) |")  # fmt: skip
        L.append("|---|---|---|---|---|---|---|---|---|---|---|")
        for r in rig:
            tc = float(r["crest_time_s"])
            L.append(
                f"| {_f(r['a_over_h'], 'g')} | {_f(r['d_over_h'], 'g')} | {r['status'][:30]} | "
                f"**{_f(r['peak_uplift'], '.1f')}** | {_f(r['peak_uplift_smooth'], '.1f')} | "
                f"{_f(r['peak_over_rho_g_a_l'], '.2f')} | "
                f"{float(r['peak_time_s']) - tc:+.3f}, "
                f"{float(r['peak_smooth_time_s']) - tc:+.3f} | "
                f"{float(r['contact_time_s']) - tc:+.3f} | {_f(r['min_uplift'], '.1f')} | "
                f"{_f(r['peak_horizontal'], '.1f')} | "
                + "{:.1f} ... {:.1f} |".format(
                    *uplift_bounds(Case(float(r["a_over_h"]), float(r["d_over_h"])))
                )
            )
        L.append("")
    if ela:
        L.append("### Elastic plate\n")
        L.append("| A/H | D/H | status | peak uplift (N/m) | 11 ms mean peak | first-slam peak "
                 "| t_peak - t_c (s) | mid-span up / down (mm) | at t - t_c (s) | windows "
                 "| iterations | unconverged windows | interface work error |")  # fmt: skip
        L.append("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
        for r in ela:
            tc = float(r["crest_time_s"])
            L.append(
                f"| {_f(r['a_over_h'], 'g')} | {_f(r['d_over_h'], 'g')} | {r['status'][:30]} | "
                f"**{_f(r['peak_uplift'], '.1f')}** | {_f(r['peak_uplift_smooth'], '.1f')} | "
                f"{_f(r['first_peak'], '.1f')} | {float(r['peak_time_s']) - tc:+.3f} | "
                f"{_f(r['mid_disp_max_mm'], '.2f')} / {_f(r['mid_disp_min_mm'], '.2f')} | "
                f"{float(r['mid_disp_max_time_s']) - tc:+.3f} | {r['windows']} | "
                f"{r['iterations']} | {r['unconverged_windows']} | "
                f"{_f(r['interface_work_error_pct'], '.1f')} % |"
            )
        L.append("")
    # ---- MF
    L.append("### Magnification factor MF = F_elastic,max / F_rigid,max\n")
    L.append("Ours: raw peaks (11 ms running-mean peaks in brackets); thesis ch. 5.1.3 (its text "
             "gives A/H = 0.2, 0.3 and 0.5; A/H = 0.4 only in Fig. 5-13).\n")  # fmt: skip
    L.append("| A/H | " + " | ".join(f"D/H = {d:g}: ours | thesis" for d in CLEARANCES) + " |")
    L.append("|---|" + "---|---|" * len(CLEARANCES))
    for a in RATIOS:
        cells = []
        for d in CLEARANCES:
            e, g = by.get(("elastic", a, d)), by.get(("rigid", a, d))
            if e and g and float(g["peak_uplift"]) > 0:
                mf = float(e["peak_uplift"]) / float(g["peak_uplift"])
                mfs = float(e["peak_uplift_smooth"]) / float(g["peak_uplift_smooth"])
                cells.append(f"**{mf:.2f}** ({mfs:.2f})")
            else:
                cells.append("not run")
            th = THESIS_MF.get((a, d))
            cells.append(f"{th:.2f}" if th is not None else "(figure only)")
        L.append(f"| {a:g} | " + " | ".join(cells) + " |")
    L.append("")
    L.append(f"![uplift histories](figures/bottom_slamming_forces_{l0_label}.png)\n")
    L.append(f"![peaks and MF](figures/bottom_slamming_mf_{l0_label}.png)\n")
    if ela:
        L.append(f"![mid-span displacement](figures/bottom_slamming_displacement_{l0_label}.png)\n")
    # ---- thesis timing
    key = ("rigid", 0.3, 0.1)
    L.append("### Timing against the thesis (A/H = 0.3, D/H = 0.1)\n")
    L.append("| event | thesis | ours |")
    L.append("|---|---|---|")
    r = by.get(key)
    e = by.get(("elastic", 0.3, 0.1))
    L.append(f"| first contact | {THESIS_TIMES['contact']} s (Fig. 5-7) | "
             f"{_f(r['contact_time_s'], '.3f') + ' s' if r else 'not run'} |")  # fmt: skip
    L.append(f"| rigid peak (crest at the front edge) | {THESIS_TIMES['rigid_peak']} s "
             f"(Figs. 5-6, 5-7) | {_f(r['peak_time_s'], '.3f') + ' s' if r else 'not run'} "
             f"(11 ms mean: {_f(r['peak_smooth_time_s'], '.3f') + ' s' if r else '-'}) "
             f"(design crest at the front edge: {Case(0.3, 0.1).crest_time:.3f} s) |")  # fmt: skip
    L.append(f"| elastic largest uplift (\"second slam\") | {THESIS_TIMES['second_slam']} s "
             f"(Fig. 5-11) | {_f(e['peak_time_s'], '.3f') + ' s' if e else 'not run'} |")  # fmt: skip
    L.append("")
    # ---- wall time
    L.append("## Cost\n")
    L.append("One numba thread (`NUMBA_NUM_THREADS=1`), one case after another, on the shared "
             "2-core development machine while other jobs ran.\n")  # fmt: skip
    L.append("| kind | A/H | D/H | fluid particles | particles | fluid steps | simulated (s) | "
             "wall time (s) | us per particle-step |")  # fmt: skip
    L.append("|---|---|---|---|---|---|---|---|---|")
    for k in order:
        r = by[k]
        steps, n = int(r["steps"]), int(r["particles"])
        wall = float(r["wall_time_s"])
        us = 1e6 * wall / (steps * n) if steps > 0 and n > 0 else math.nan
        L.append(f"| {r['kind']} | {_f(r['a_over_h'], 'g')} | {_f(r['d_over_h'], 'g')} | "
                 f"{r['fluid_particles']} | {r['particles']} | {steps} | "
                 f"{_f(r['t_end_s'], '.3f')} | {wall:.0f} | {_f(str(us), '.2f')} |")  # fmt: skip
    L.append("")
    measured = resolution_runs(l0_label, rows)
    if measured:
        L.append(measured)
    L.append(resolution_cost(rows))
    L.append(DISCUSSION)
    L.append(RUNNING)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text("\n".join(L).rstrip() + "\n")


def resolution_runs(l0_label: str, rows: list[dict[str, str]]) -> str:
    """The cases run at the thesis's spacings (Table 5-1; `--l0 0.0025` etc. write their own
    CSV) next to the same case at this spacing: peak uplift, its 11 ms running mean and time,
    mid-span displacement (elastic), steps and wall time."""
    here = {(r["kind"], float(r["a_over_h"]), float(r["d_over_h"])): r for r in rows}
    found = []
    for l0, *_ in sorted(THESIS_TABLE_5_1, reverse=True):
        path = RESULTS_DIR / f"bottom_slamming_{l0:g}.csv"
        if f"{l0:g}" == l0_label or not path.is_file():
            continue
        found += [(f"{l0:g}", r) for r in read_csv(path)]
    if not found:
        return ""
    keys = sorted({(r["kind"], float(r["a_over_h"]), float(r["d_over_h"])) for _, r in found})
    out = ["### Resolution study (thesis Table 5-1): measured\n"]
    out.append("| kind | A/H | D/H | l0 (m) | status | fluid particles | peak uplift (N/m) | at (s) | "
               "11 ms mean peak (N/m) | uplift impulse, contact to window end (N s/m) | "
               "mid-span up (mm) | steps | wall time (s) |")  # fmt: skip
    out.append("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for key in keys:
        runs = [here[key]] if key in here else []
        runs += [r for _, r in found if (r["kind"], float(r["a_over_h"]),
                 float(r["d_over_h"])) == key]  # fmt: skip
        for r in runs:
            out.append(
                f"| {r['kind']} | {_f(r['a_over_h'], 'g')} | {_f(r['d_over_h'], 'g')} | "
                f"{_f(r['l0'], '.5g')} | {r['status']} | {r['fluid_particles']} | "
                f"{_f(r['peak_uplift'], '.1f')} | {_f(r['peak_time_s'], '.3f')} | "
                f"{_f(r['peak_uplift_smooth'], '.1f')} | {_f(r.get('uplift_impulse', ''), '.2f')} | "
                f"{_f(r['mid_disp_max_mm'], '.2f')} | "
                f"{r['steps']} | {_f(r['wall_time_s'], '.0f')} |"
            )
    out.append(
        f"\nThe first row of a case is this document's run (l0 = {l0_label} m); finer spacings "
        "are run with `python validation/bottom_slamming.py --l0 0.0025 --cases 0.3:0.1 --kinds "
        f"rigid`, then `--analyse-only --l0 {l0_label}` regenerates this document.\n"
    )
    return "\n".join(out)


def resolution_cost(rows: list[dict[str, str]]) -> str:
    """Extrapolated cost of the thesis's resolution study (Table 5-1) from the measured runs:
    particles scale with (l0_ours / l0)^2; steps lie between the measured count (dt_max-bound)
    and the measured count x l0_ours / l0 (Courant-bound everywhere); cost per particle-step as
    measured (us per particle and fluid step, the elastic runs' including the coupling)."""
    out = ["### Resolution study (thesis Table 5-1): estimated cost of the whole study\n"]
    ref = {}
    for kind in KINDS:
        sel = [r for r in rows if r["kind"] == kind and r["status"] == "finished"
               and int(r["steps"]) > 0 and int(r["particles"]) > 0]  # fmt: skip
        if sel:
            r = next((x for x in sel if float(x["a_over_h"]) == 0.3 and float(x["d_over_h"]) == 0.1),
                     sel[0])  # fmt: skip
            ref[kind] = r
    if not ref:
        out.append("No finished run to extrapolate from.\n")
        return "\n".join(out)
    out.append("| l0 (m) | layers over H | thesis fluid particles / elements | ours: fluid / all "
               "particles (est.), elements | " + " | ".join(f"{k} case: hours on one thread"
               for k in ref) + " |")  # fmt: skip
    out.append("|---|---|---|---|" + "---|" * len(ref))
    total = [0.0, 0.0]
    for l0, _, n_thesis, el_thesis in sorted(THESIS_TABLE_5_1, reverse=True):
        sp = spacing_for(l0)
        cells = []
        n_fluid = n_all = 0
        for r in ref.values():
            l0_run = float(r["l0"])
            scale = (l0_run / sp) ** 2
            n_all = int(round(int(r["particles"]) * scale))
            n_fluid = int(round(int(r["fluid_particles"]) * scale))
            steps = int(r["steps"])
            us = float(r["wall_time_s"]) / (steps * int(r["particles"]))
            lo = us * n_all * steps / 3600.0
            hi = us * n_all * steps * (l0_run / sp) / 3600.0
            total[0] += lo
            total[1] += hi
            cells.append(f"{lo:.1f} ... {hi:.1f}")
        out.append(f"| {l0:g} (-> {sp:.5g}) | {round(DEPTH / sp)} | {n_thesis} / {el_thesis} | "
                   f"{n_fluid} / {n_all}, {elements_for(sp)} | " + " | ".join(cells) + " |")  # fmt: skip
    refs = ", ".join(f"{k}: A/H = {r['a_over_h']}, D/H = {r['d_over_h']}" for k, r in ref.items())
    out.append(
        f"\nExtrapolated from the measured runs ({refs}) at their measured cost per particle and "
        "fluid step (the elastic runs' including their ~5 % repeated iterations and the "
        "coupling; measured on a loaded machine, 8-12 us against about 5.5 us on an idle core); "
        "the range is dt_max-bound (as many steps as measured) to Courant-bound (steps x l0 "
        f"ratio). The whole study (one case, {' and '.join(ref)}, three spacings) would take "
        f"{total[0]:.0f} to {total[1]:.0f} hours on one thread. "
        "`python validation/bottom_slamming.py --l0 0.002 --cases 0.3:0.1` runs one spacing "
        "(resumable, `--threads 2` where the cores are free).\n"
    )
    return "\n".join(out)


DEFINITIONS = """## Definitions

- **Uplift** F(t): the y component of the fluid's pressure force on the plate, probe `uplift`,
  N per metre of width (2D), sampled every 1 ms: -sum p_i l0 n_i over the plate's pressure-layer
  particles (rigid: the wall box's bottom, top and end faces; elastic: both faces and the end
  caps of the member, thesis eq. 2-51). Positive upwards.
- **Peak window**: from t = 0 until the foot (eta = 10 % of A, 1.82/k ahead of the crest) of
  the wave sent back by the sponge's inner edge (x = 2.0 m) reaches the plate's rear edge:
  t_c + (2.0 - 1.82/k - 1.2) / c + (2.0 - 1.505) / sqrt(g H), t_c = design crest at the front
  edge (t_c + 0.70 s at A/H = 0.2 to t_c + 0.82 s at 0.5); the sponge sends back at most about
  half of what reaches it, so less than 5 % of A has come back by then. The rigid runs end
  earlier, at t_c + 0.6 s, when their uplift is over; the elastic runs at the window's end.
  **Peak uplift** = the largest sample in it (what the thesis reports as the maximum uplift); **11 ms mean peak** = the largest value of the
  11 ms centred running mean (MPS pressures spike for one or two steps; this is the peak of the
  load a structure with periods above ~20 ms feels).
- **MF** = F_elastic,max / F_rigid,max (thesis ch. 5.1.3), same case, same window.
- **First-slam peak** (elastic): the largest uplift until the mid-span's first upward maximum;
  after it the plate comes back down onto the water (the thesis's "second slam").
- **Contact**: the first sample with F above 2 % of the peak.
- **Bounds of the mean peak** (rigid; the CI and slow tests check them): lower, the
  quasi-static uplift rho g integral of max(eta - D, 0) over the plate of the undisturbed
  first-order wave with its crest at the front edge (when the thesis's rigid peak occurs);
  upper, the largest such quasi-static uplift over all crest positions plus a Wagner-type
  slamming part rho c w L, the wetted length growing at the wave speed c while the surface meets
  the plate at most at the wave's largest rise speed w = c A k 4 / (3 sqrt 3)
  (`uplift_bounds`).
- **Interface work error** (elastic): the largest |sum (W_s - W_f)| over the run, the energy the
  interface created (docs/coupler.md), as % of the structure's largest energy.
- **rho g A L**: the hydrostatic scale of the uplift, the pressure under a crest A high on the
  whole plate length L = 0.305 m if the plate sat at the still-water level.
"""

RUNNING = """## Running

    NUMBA_NUM_THREADS=1 python validation/bottom_slamming.py --l0 0.004 --cases 0.3:* --kinds rigid,elastic
    python validation/bottom_slamming.py --l0 0.004 --analyse-only     # CSV, figures, this page

Results files `validation/results/bottom_slamming_<l0>_<kind>_AH<A/H>_DH<D/H>.h5` (not
committed); a finished one is skipped, one interrupted by a kill resumes from its checkpoint,
a failed one is rerun only with `--retry-failed`.
"""

DISCUSSION = """## Discussion

**Rigid plate.** The uplift starts when the front of the wave reaches the plate (0.24-0.35 s
before the design crest reaches the front edge at A/H = 0.3) and is largest within 0.1 s of t_c,
as the thesis describes (peak at 1.96 s when the crest reaches the front edge, Figs. 5-6, 5-7).
For A/H = 0.3, D/H = 0.1 our first contact (1.716 s) is 0.04 s before the thesis's 1.76 s and the
peak (1.857 s) 0.10 s before its 1.96 s, while our crest arrives on the design time (the wave
tank gives the crest at 1.2 m within 1 ms of it at A/H = 0.3). The record is very noisy: single samples
jump between near zero and two to three times the 11 ms mean from one step to the next (the grey
bands in the figure). These are pressure spikes of the few particles in the gap between the
plate and the rising water, which switch between free surface (Dirichlet pressure) and interior
from step to step. The raw peak (the largest sample, what "maximum uplift" means in the thesis)
is therefore 1.7-2.7 times the 11 ms-mean peak here and is an envelope of that noise rather than
a converged load; the thesis itself found the first peak of the vertical force clearly higher at
its coarsest spacing (0.0025 m, Fig. 5-3) than at 0.002 and 0.0015 m. The 11 ms-mean peaks lie
between the quasi-static bounds (lower: crest at the front edge; upper: largest quasi-static
uplift plus a Wagner-type slamming part) in every rigid case run. At A/H = 0.2 and 0.3 they fall
with the clearance (62.5, 56.8, 44.3 N/m and 123.7, 77.4, 65.4 N/m for D/H = 0.03, 0.06, 0.1),
as the thesis's Fig. 5-8 shows, and they grow with A/H at D/H = 0.06 and 0.1 (56.8, 77.4,
99.6, 119.1 and 44.3, 65.4, 98.5, 121.2 N/m for A/H = 0.2, 0.3, 0.4, 0.5). At A/H = 0.4 and
0.5 they hardly change with the clearance (94.7, 99.6, 98.5 and 108.8, 119.1, 121.2 N/m), and
A/H = 0.3, D/H = 0.03 (123.7 N/m) lies above A/H = 0.4 and 0.5 at the same clearance, its peak
a single 0.1 s bump after t_c (figure); with the raw samples spiking at two to three times
these means, differences of 5-25 % are within what this spacing resolves. The thesis reports
the uplift proportional to the wave height and less sensitive to the clearance, which the means
follow at D/H = 0.06 and 0.1 (nearly linear in A/H, 2.0-2.7 times from A/H = 0.2 to 0.5). The
thesis gives its
rigid peaks only in that figure, and the measurements of Seiffert et al. behind it are not in our
sources, so forces cannot be compared number to number; the thesis notes that all its numerical
peaks exceed the experiment's (no air cushion in a single-phase model, also true here).

**D/H = 0.03 at this spacing** is 0.84 l0: the still water's top particles are already within
the number-density radius (2.1 l0) of the plate's bottom wall layer, so the plate feels the
water as soon as the wave's foot lifts the surface by a fraction of a spacing (contact 0.35 s
before t_c against 0.24 s for D/H = 0.1). The thesis's 0.002 m resolves this clearance by
1.7 spacings.

**Elastic plate: no magnification.** With the section that follows from the stated thickness
(E = 1 MPa, I = t^3/12 per unit width, 15.6 kg/m^2, simply supported; the choice of
scenarios/structure_bottom_slamming_2d.toml) the elastic plate's largest uplift is a third to
a half of the rigid plate's at A/H = 0.3 (MF = 0.42, 0.34 and 0.33 at D/H = 0.03, 0.06 and
0.1; thesis 3.23, 5.28 and 3.66), and below one in all twelve cases (A/H = 0.2: 0.21-0.36,
0.4: 0.61-0.69, 0.5: 0.44-0.61; the thesis's 1.24-6.35). MF grows with A/H, as the plate lags
further behind a faster-rising surface, but stays below one. At A/H = 0.3 the plate rises by 17-24 mm (seven times the clearance at D/H = 0.03)
at up to 0.10 m/s, nearly as
fast as the water surface below it rises (0.13 m/s for the first-order wave), so the water meets
a receding plate and the slamming pressure is relieved: 11 ms-mean peaks of 19-26 N/m against
65-124 N/m for the rigid plate. Its largest uplift comes 0.07 s after t_c at D/H = 0.06 and 0.1
(2.025 s at D/H = 0.1, against the thesis's "second slam" at 2.12 s), during the first loading,
not after a rebound. It turns at t_c + 0.13-0.14 s and swings down at most 0.11-0.12 m/s,
reaching its lowest point (7.5-9.2 mm below rest) at t_c + 0.49-0.63 s, when the crest has long
passed: it meets only the back of the wave and no "second slam" appears. Its wet first period is
about 1 s (dry: 2.27 Hz); the water under it adds about rho / k_1 coth(k_1 H) = 117 kg/m^2,
k_1 = pi / L, seven times its own mass.

The thesis's time line (first peak 1.96 s, separation from the water 2.02 s, "second slam" with
the largest uplift at 2.12 s, Fig. 5-11) needs a plate that turns round within about 0.1 s, a
period of 0.3-0.4 s, three times faster than ours. Its tables (A = 2.5e-5 m^2, I = 1e-3 m^4)
contradict its 0.015 m thickness; read with I = 1e-9 m^4 they give 3.3 Hz dry but a mass of
0.026 kg/m, and with that plate (added-mass ratio of order 10^3) our coupled run blew up at the
first contact (tried at l0 = H/12: particle velocities of 10^4 m/s within a few windows). We
cannot tell what plate the thesis ran; what this set-up supports is hydroelastic relief
(MF < 1, asserted by the slow test), not the thesis's magnification.

**Coupling.** Implicit IQN-ILS needed 1.04-1.05 iterations per 1 ms window on average (most
windows converge at once: the plate moves smoothly and the relative tolerance is 1e-3); one
window (D/H = 0.1, at the first contact, 1.712 s) did not converge in 30 iterations and was
accepted as configured. But the interface created 2.7-4.7 % of the structure's largest energy (the
interface work error). The cause is the coupling tolerance, not the mapping (the fluid's
interface points are fixed, no window rebuilds it; KFBI gives about the same): rtol is relative
to the whole plate displacement, and a 1 ms window moves the plate by about 0.7 % of it, so the
predictor d_n + T v_n (error about 1.8e-4 of rms(d)) is already within 1e-3 and 89 % of the wet
windows were accepted at their first iterate: the run is coupled almost explicitly (the H/28
runs' 1.04-1.05 iterations per window say the same). Measured at l0 = H/12, 0-2.3 s
(docs/coupler.md, "Records and the interface energy balance"): 5.4 % at rtol 1e-3 (1.04
iterations per window), 6.3 % explicit, 0.53 % at rtol 1e-4 (1.39 iterations per window); a
second forced iteration (`min_iterations = 2`) left it at 4.6 %. These figures use the corrected
fluid-side work of commit c103188 (the CSV's A/H = 0.2, 0.3 rows and A/H = 0.4, D/H = 0.03
were computed before it, the other A/H = 0.4 and 0.5 rows after it, 3.2-4.8 %: at H/12 the old
bookkeeping gave 8.6 % at rtol 1e-3 and 0.25 % at 1e-4). For runs whose energy matters, use rtol
1e-4 (a third more fluid solves over this run).

**Resolution (measured 2026-11-21 and 22, table above).** For A/H = 0.3, D/H = 0.1 the rigid
plate's integrated load settles at the thesis's spacings but its peaks do not: from l0 = 0.004 over
0.0025 and 0.002 to 0.0015 m the uplift impulse from contact to the window's end is 10.9,
12.3, 14.0, 12.9 N s/m (the three thesis spacings within 7 % of their mean, H/28 16 % below
it), while the raw peak goes 157, 163, 231, 221 N/m and the 11 ms mean peak 65, 99, 142,
99 N/m. A flat plate meeting a rising surface is the zero-deadrise limit of slamming, where
incompressible theory has no finite pressure peak: each lattice resolves its own short spike,
and which particles hit first changes with the lattice. Use the impulse, not the peak, to
compare rigid-plate runs. The thesis judged convergence on the elastic plate (Figs. 5-2,
5-3). On the elastic plate the displacement converges and the load roughly settles: from
0.004 over 0.0025 and 0.002 to 0.0015 m its mid-span rise goes 16.9, 18.2, 18.5, 18.9 mm (the
three thesis spacings within 2 % of their mean, the steps 7.5, 1.5, 2.3 %) and its peak uplift
52.6, 51.6, 47.8, 57.4 N/m (the three thesis spacings within 10 % of their mean, 52.3 N/m,
against the rigid peak's spread of 157-231 N/m), because the plate moving away with the water
relieves the impact. Its 11 ms mean peak (20.8, 17.7, 34.2, 22.4 N/m) and the impulse from
contact to the window's end (4.0, 1.6, 2.8, 3.1 N s/m: a small balance of the uplift and the
later downward load on the rebounding plate) are not converged. MF (0.33, 0.32, 0.21, 0.26)
inherits the rigid peak's lack of convergence (157, 163, 231, 221 N/m): it is below one at
every spacing, but its value at a given spacing is only as good as the rigid spike it divides
by. The coupling behaves the same at every thesis spacing: 1.04-1.05 iterations per window
(2827, 2838 and 2860 in 2730 windows at 0.0025, 0.002 and 0.0015 m, none unconverged),
interface work error 1.8, 1.1 and 1.2 % of the structure's largest energy. Wall time on one
thread (other runs beside it): 970, 1831 and 5850 s for the elastic runs at 0.0025, 0.002 and 0.0015 m (46 414, 71 250 and 126 692 fluid particles;
3220, 3586 and 4977 steps), 954, 1858 and 4035 s for the rigid ones.

**Artificial compressibility, one case.** The rigid plate at A/H = 0.3, D/H = 0.1 was rerun at
0.004 m with the case's overrides plus `--set fluid.pressure.compressibility=1e-6`: sound speed
31.6 m/s, 26 times the solitary wave's celerity (1.2 m/s). The option is consistent since 2026-11-22
(docs/fluid.md); 229 s wall on one thread.

| | incompressible | compressibility 1e-6 1/Pa |
|---|---|---|
| peak uplift | 157.4 N/m at 1.857 s | 122.9 N/m at 1.891 s |
| 11 ms mean peak | 65.4 N/m at 1.859 s | 101.8 N/m at 1.890 s |
| raw peak / mean peak | 2.41 | 1.21 |
| contact | 1.716 s | 1.744 s |
| uplift impulse | 10.88 N s/m | 8.07 N s/m |

- The record is far less noisy: the raw peak is 1.21 times the 11 ms mean peak instead of 2.41.
- The mean peak stays inside the quasi-static bounds (35.0 ... 105.0 N/m), but it moved by 56 %.
- Which of the two is nearer the converged load would take the spacing study repeated with
  compressibility (4000-6000 s per run). That was not done, and neither was the thesis's wall
  model (`fluid.pressure.wall_model = "pressure_layer"`).
"""


# ---------------------------------------------------------------------- main
def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--l0", default="0.004", help="particle spacing, m (default 0.004)")
    ap.add_argument("--cases", default="all", help="'all' or A/H:D/H pairs, e.g. 0.3:0.06,0.2:*")
    ap.add_argument("--kinds", default="rigid,elastic", help="rigid, elastic or both")
    case_runner.add_run_options(ap)
    args = ap.parse_args(argv)
    l0 = float(args.l0)
    if not l0 > 0.0:
        ap.error(f"--l0 = {args.l0}: must be > 0")
    try:
        cases = parse_cases(args.cases)
    except ValueError as exc:
        ap.error(str(exc))
    kinds = [k.strip() for k in args.kinds.split(",") if k.strip()]
    for k in kinds:
        if k not in KINDS:
            ap.error(f"--kinds: {k!r} is not one of {', '.join(KINDS)}")
    spacing = spacing_for(l0)
    print(
        f"l0 = {l0:g} m -> {spacing:.7g} m: {round(DEPTH / l0)} layers over H = {DEPTH} m; "
        f"{elements_for(spacing)} beam elements of {PLATE_LENGTH / elements_for(spacing):.5g} m"
    )
    RESULTS_DIR.mkdir(parents=True, exist_ok=True)
    if not args.analyse_only:
        for case in cases:  # the rigid and elastic runs of a case one after the other
            for kind in kinds:
                out = case_path(args.l0, kind, case)
                ensure_case(kind, case, spacing, out, args.threads, args.retry_failed)
    return report(args.l0)


if __name__ == "__main__":
    sys.exit(main())
