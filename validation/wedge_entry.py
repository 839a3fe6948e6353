"""Rigid wedge entering calm water at constant speed: Wagner (1932) and Zhao & Faltinsen (1993).

Runs scenarios/wedge_entry_2d.toml (a polygon wall, the wedge, moved down at V = 5 m/s into
weightless water; its comments give the set-up and why) at deadrise 10 and 30 deg and three
spacings l0 = B / n (n = 20, 40, 80 by default; B = 0.2 m the half-breadth), in this process on
NUMBA_NUM_THREADS threads (default 1), one case after another, reading every step's vertical
force on the wedge and the pressure of every pressure-layer particle of its faces. Each case is
kept in validation/results/wedge_entry/<case>.npz (a case with its file is not run again). Then

* validation/results/wedge_entry.csv: one row per case (columns :data:`COLUMNS`);
* printed: the same table, the observed convergence orders and the wall times.

Measures, over the window in which Wagner's wetted half-width c(t) = (pi / 2) V t / tan(beta)
grows from 0.3 B to 0.6 B (the run ends there; before it c / l0 is too small to resolve):

* ``cf_impulse``: the force coefficient C_F = F / (rho V^3 t) from the impulse the wedge receives
  in the window, C_F = 2 (I(t2) - I(t1)) / (rho V^3 (t2^2 - t1^2)) (F = C_F rho V^3 t integrated);
  an impulse is immune to the step-to-step spikes of incompressible MPS pressure, which carry
  little momentum; ``cf_fit``: the least-squares slope of F against t through the origin;
* ``cp_max``: the peak of the similarity profile: every sample of face pressure in the window is
  binned by xi = |x| / c(t) (bins 0.05 wide; x horizontal from the apex) and averaged per bin,
  Cp = p / (rho V^2 / 2); Cp_max is the largest bin mean. The flow is self-similar at constant V,
  so each bin averages the same physical pressure seen by many particles at many times: the
  spikes average out while the peak, which moves with c(t), is not smeared by time averaging at a
  fixed point; ``xi_peak`` is its bin centre (Wagner: at xi -> 1, Zhao & Faltinsen: just short of
  the spray root). ``cp_spike``: the largest single-particle, single-step value in the window, to
  show the spread a raw maximum has;
* ``impulse_ratio``: the pressure impulse int p dt from t = 0 to the end at the face particle
  nearest |x| = 0.25 c_end (both faces averaged) over Wagner's rho V sqrt(c_end^2 - x^2) (the
  integral of Wagner's p = rho V c c' / sqrt(c^2 - x^2) once c has passed x; finite although p is
  singular).

References (docs/validation_water_entry.md, where the sources searched are listed):

* Wagner (1932): C_F = pi^3 / (4 tan^2 beta), Cp_max = (pi / (2 tan beta))^2 (references.md
  section 8);
* the modified Logvinovich model (MLM, Korobkin 2004, Eur. J. Appl. Math. 15: 821-838), the
  generalised Wagner model used here: Wagner's wetted half-width c(t) and flat-plate potential,
  Bernoulli's full pressure on the real wedge surface, integrated where it is positive. At
  constant V it gives p / (rho V^2) = k / sqrt(1 - xi^2) - 1/2 - xi^2 cos^2(beta) /
  (2 (1 - xi^2)), k = pi / (2 tan beta), xi = |x| / c, and in closed form the force and the peak
  of :func:`mlm_cf` and :func:`mlm_cp_max` (``cf_mlm``, ``cp_mlm``); ``cp_mlm_bin``
  (:func:`mlm_cp_binned`) is its peak measured as ``cp_max`` is, over bins of xi;
* Zhao & Faltinsen (1993)'s similarity solution: Cp_max = 6.93 at 30 deg and 54.3 at 10 deg,
  values as commonly cited from their table, NOT verified (no readable copy of the paper or of a
  table quoting it was found); the 10 deg value is doubtful (it is 0.68 of Wagner's, where the
  exact peak tends to Wagner's as beta -> 0). Their force coefficients were not found.

A second file, ``validation/results/wedge_entry_convergence.csv``, holds the observed
convergence of each quantity over each three consecutive spacings: the changes, whether they
are monotone, the observed order and, where the sequence is monotone with a positive order, the
Richardson estimate q3 + (q3 - q2) / (2^p - 1); and the finest value over each reference.

    python validation/wedge_entry.py [--betas 10,30] [--levels 20,40,80] [--threads 1]
                                     [--tank-levels 20,40] [--variants dt05:40,gravity:40]
                                     [--analyse-only]

The published table: ``--levels 20,40,80,160 --tank-levels 20,40 --variants
dt05:40,gravity:40`` (the B / 160 runs first, one deadrise at a time: ``--betas 10 --levels
160``). ``--analyse-only`` rewrites both CSVs from the kept files of the levels given: pass
every level (``--levels 20,40,80,160``) or the CSVs lose the rows of the others.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
SCENARIO = ROOT / "scenarios" / "wedge_entry_2d.toml"
OUT_DIR = ROOT / "validation" / "results" / "wedge_entry"
CSV = ROOT / "validation" / "results" / "wedge_entry.csv"
CONVERGENCE_CSV = ROOT / "validation" / "results" / "wedge_entry_convergence.csv"

# set-up of scenarios/wedge_entry_2d.toml (the script rebuilds the wedge per deadrise)
B = 0.2  # half-breadth, m
V = 5.0  # entry speed, m/s
RHO = 1000.0  # kg/m^3
H = 0.3  # still-water depth, m (the apex starts on the surface)
HALF_WIDTH = 0.4  # tank half-width, m
C_START, C_END = 0.3, 0.6  # window: Wagner's c(t) / B
BIN = 0.05  # similarity bin width in xi = |x| / c
#: the wedge moves at most this many spacings per step (dt_max = this x l0 / V): enough samples
#: of the spiky pressure in the measured window at every spacing (at 10 deg the Courant limit
#: alone left 13 steps in it at B / 20)
DT_MAX_PER_SPACING = 0.02
IMPULSE_XI = 0.25  # face point of the pressure impulse, |x| / c_end
#: Zhao & Faltinsen (1993) similarity solution, Cp_max by deadrise (deg), as commonly cited:
#: NOT verified against the paper (docs/validation_water_entry.md); 54.3 at 10 deg is doubtful
ZF_CP_MAX = {10: 54.3, 30: 6.93}

COLUMNS = [
    "beta_deg", "n", "l0", "tank", "variant", "particles", "steps", "wall_s",
    "cf_impulse", "cf_fit", "cf_wagner", "cf_ratio", "cf_mlm", "cf_ratio_mlm",
    "cf_half1", "cf_half2", "cf_pressure",
    "cp_max", "xi_peak", "cp_spike", "cp_wagner", "cp_ratio_wagner", "cp_mlm", "cp_mlm_bin",
    "cp_ratio_mlm_bin", "cp_zf", "cp_ratio_zf", "impulse_ratio",
]  # fmt: skip
#: the quantities whose convergence is reported, and the reference columns of each
CONVERGED = {
    "cf_impulse": ("cf_wagner", "cf_mlm"),
    "cp_max": ("cp_wagner", "cp_mlm", "cp_mlm_bin", "cp_zf"),
    "impulse_ratio": (),
}
CONVERGENCE_COLUMNS = [
    "beta_deg", "quantity", "n1", "n2", "n3", "q1", "q2", "q3", "change12", "change23",
    "monotone", "order", "richardson", "finest", "ref_wagner", "ref_mlm", "ref_mlm_bin",
    "ref_zf", "finest_over_wagner", "finest_over_mlm", "finest_over_mlm_bin", "finest_over_zf",
]  # fmt: skip


def wagner_speed(beta: float) -> float:
    """dc/dt = (pi / 2) V / tan(beta), m/s (Wagner 1932; references.md section 8)."""
    return 0.5 * math.pi * V / math.tan(beta)


def wagner_cf(beta: float) -> float:
    """F / (rho V^3 t) = pi^3 / (4 tan^2 beta) (Wagner; references.md section 8)."""
    return math.pi**3 / (4.0 * math.tan(beta) ** 2)


def wagner_cp_max(beta: float) -> float:
    """Cp_max = (pi / (2 tan beta))^2 (Wagner, the outer-solution limit; references.md 8)."""
    return (math.pi / (2.0 * math.tan(beta))) ** 2


def _mlm_xi0(beta: float) -> float:
    """Where the MLM pressure (module docstring) falls to zero, xi0 = sqrt(1 - u^2) with u the
    small root of sin^2(b) u^2 - 2 k u + cos^2(b) = 0, u = sqrt(1 - xi^2), k = pi / (2 tan b)."""
    k = 0.5 * math.pi / math.tan(beta)
    sc = math.sin(beta) * math.cos(beta)
    u = sc**2 / (math.sin(beta) ** 2 * (k + math.sqrt(k * k - sc**2)))  # small root, stable form
    return math.sqrt(1.0 - u * u)


def mlm_pressure(xi: np.ndarray | float, beta: float) -> np.ndarray | float:
    """MLM face pressure over rho V^2 at xi = |x| / c (Korobkin 2004, modified Logvinovich model:
    potential -V (sqrt(c^2 - x^2) + f(x) - h) on the face, full Bernoulli; constant V, wedge
    f = |x| tan b): p / (rho V^2) = k / sqrt(1 - xi^2) - 1/2 - xi^2 cos^2 b / (2 (1 - xi^2))."""
    k = 0.5 * math.pi / math.tan(beta)
    xi = np.asarray(xi, dtype=float)
    return k / np.sqrt(1.0 - xi**2) - 0.5 - 0.5 * xi**2 * math.cos(beta) ** 2 / (1.0 - xi**2)


def mlm_cf(beta: float) -> float:
    """F / (rho V^3 t) of the MLM (Korobkin 2004), the pressure :func:`mlm_pressure` integrated
    over both faces where it is positive, |xi| < xi0: F / (rho V^3 t) = 2 k [k asin(xi0) - xi0 / 2
    - (cos^2 b / 2)(atanh(xi0) - xi0)] (c = k V t, dx = c dxi)."""
    k = 0.5 * math.pi / math.tan(beta)
    x0 = _mlm_xi0(beta)
    c2 = math.cos(beta) ** 2
    return 2.0 * k * (k * math.asin(x0) - 0.5 * x0 - 0.5 * c2 * (math.atanh(x0) - x0))


def mlm_cp_max(beta: float) -> float:
    """Peak of 2 :func:`mlm_pressure` (= Cp) over 0 <= xi < xi0, where d/dxi = 0:
    k xi (1 - xi^2)^(-3/2) = xi cos^2 b (1 - xi^2)^(-2), i.e. sqrt(1 - xi^2) = cos^2 b / k (or the
    apex if that has no root). Korobkin (2004)'s model is an outer solution: near the spray root
    it is not the jet's inner solution, so this peak is a model value, not the exact one."""
    k = 0.5 * math.pi / math.tan(beta)
    u = math.cos(beta) ** 2 / k
    xi = math.sqrt(1.0 - u * u) if u < 1.0 else 0.0
    return 2.0 * float(mlm_pressure(xi, beta))


def _mlm_integral(xi: float, beta: float) -> float:
    """int_0^xi of :func:`mlm_pressure` (closed form: k asin(xi) - xi / 2 - (cos^2 b / 2)
    (atanh(xi) - xi)), for 0 <= xi <= xi0 < 1."""
    k = 0.5 * math.pi / math.tan(beta)
    return k * math.asin(xi) - 0.5 * xi - 0.5 * math.cos(beta) ** 2 * (math.atanh(xi) - xi)


def mlm_cp_binned(beta: float, width: float = BIN) -> float:
    """The MLM's Cp = 2 p / (rho V^2) as this script measures a peak: averaged over bins of xi
    ``width`` wide (the pressure taken as 0 where it is negative and beyond the spray root), the
    largest bin mean. The like-for-like reference of ``cp_max``: a bin as wide as the narrow
    peak's neighbourhood averages it down (at 10 deg from 81.8 to 59.4)."""
    x0 = _mlm_xi0(beta)
    best = 0.0
    for j in range(int(math.ceil(x0 / width))):
        lo, hi = j * width, min((j + 1) * width, x0)
        best = max(best, 2.0 * (_mlm_integral(hi, beta) - _mlm_integral(lo, beta)) / width)
    return best


#: sensitivity variants (``--variants``): extra overrides of the scenario and what they test
VARIANTS = {
    "": "the study's set-up",
    "dt05": "dt_max = 0.05 l0 / V instead of 0.02 l0 / V (the step's effect)",
    "gravity": "g = 9.81 m/s^2 with a hydrostatic start (the Froude number's effect)",
}


def overrides(beta_deg: int, n: int, tank: float = 1.0, variant: str = "") -> list[str]:
    """--set overrides of the scenario for deadrise ``beta_deg``, spacing B / n, a tank
    ``tank`` times as wide and deep (the apex stays on the surface) and a :data:`VARIANTS`
    key."""
    beta = math.radians(beta_deg)
    depth = H * tank
    half = HALF_WIDTH * tank
    knuckle = depth + B * math.tan(beta)
    top = knuckle + 0.5 * B
    verts = [[0.0, depth], [B, knuckle], [B, top], [-B, top], [-B, knuckle]]
    t_end = C_END * B / wagner_speed(beta)
    vtxt = "[" + ",".join(f"[{x:.9g},{y:.9g}]" for x, y in verts) + "]"
    if variant not in VARIANTS:
        raise ValueError(f"variant {variant!r}: allowed {sorted(VARIANTS)}")
    dt_per_spacing = 0.05 if variant == "dt05" else DT_MAX_PER_SPACING
    extra = ["fluid.gravity=[0.0,-9.81]", "fluid.hydrostatic_start=true"]
    return (extra if variant == "gravity" else []) + [
        f"fluid.spacing={B / n:.9g}",
        f"run.end_time={t_end:.9g}",
        f"fluid.time_step.dt_max={dt_per_spacing * B / n / V:.9g}",
        f"fluid.walls.1.vertices={vtxt}",
        f"fluid.blocks.0.lower=[{-half},0.0]",
        f"fluid.blocks.0.upper=[{half},{depth}]",
        f"fluid.walls.0.lower=[{-half},0.0]",
        f"fluid.walls.0.upper=[{half},{depth + 0.2}]",
        f"probes.1.position=[0.05,{depth - 0.0036}]",
    ]


def case_name(beta_deg: int, n: int, tank: float = 1.0, variant: str = "") -> str:
    name = f"beta{beta_deg}_n{n}" + ("" if tank == 1.0 else f"_tank{tank:g}")
    return name + (f"_{variant}" if variant else "")


def run_case(
    beta_deg: int, n: int, tank: float = 1.0, variant: str = "", out_dir: Path = OUT_DIR
) -> Path:
    """Run one case (unless its file exists in ``out_dir``) and keep its histories there;
    returns the file."""
    from mpsfem.fluid_mps.particle_kinds import WALL
    from mpsfem.fluid_mps.solver import FluidSolver
    from mpsfem.scenario.loader import load_scenario

    path = out_dir / f"{case_name(beta_deg, n, tank, variant)}.npz"
    if path.is_file():
        return path
    loaded = load_scenario(SCENARIO, overrides(beta_deg, n, tank, variant))
    sc = loaded.scenario
    solver = FluidSolver(sc.fluid, base_dir=SCENARIO.parent)
    pt = solver.patch("wedge")
    idx = np.arange(pt.start, pt.stop)[solver.kind[pt.start : pt.stop] == WALL]
    apex_y = sc.fluid.walls[1].vertices[0][1]
    # face particles only (below the knuckles: the sides and top never get wet here)
    knuckle = apex_y + B * math.tan(math.radians(beta_deg))
    idx = idx[solver.pos[idx, 1] < knuckle]
    x = solver.pos[idx, 0].copy()
    t_end = sc.run.end_time
    times, dts, force, press = [], [], [], []
    t0 = time.perf_counter()
    while solver.t < t_end - 1e-12:
        dt = solver.dt_towards(t_end)
        solver.step(dt)
        times.append(solver.t)
        dts.append(dt)
        force.append(solver.boundary_force(["wedge"])[1])
        press.append(solver.p[idx].copy())
    wall = time.perf_counter() - t0
    out_dir.mkdir(parents=True, exist_ok=True)
    np.savez_compressed(
        path,
        t=np.array(times),
        dt=np.array(dts),
        force=np.array(force),
        p=np.array(press),
        x=x,
        wall_s=wall,
        particles=solver.n,
        l0=sc.fluid.spacing,
    )
    print(f"  {path.name}: {solver.n} particles, {len(times)} steps, {wall:.0f} s wall", flush=True)
    return path


def analyse(
    beta_deg: int, n: int, tank: float = 1.0, variant: str = "", out_dir: Path = OUT_DIR
) -> dict:
    """The row of one case (module docstring)."""
    d = np.load(out_dir / f"{case_name(beta_deg, n, tank, variant)}.npz")
    beta = math.radians(beta_deg)
    cdot = wagner_speed(beta)
    t, dt, f, p, x = d["t"], d["dt"], d["force"], d["p"], d["x"]
    t1, t2 = C_START * B / cdot, C_END * B / cdot
    # impulse by the rectangle rule of the step forces (each F is the step's force)
    tt = np.concatenate([[0.0], t])

    def cf_between(force: np.ndarray, ta: float, tb: float) -> float:
        impulse = np.concatenate([[0.0], np.cumsum(force * dt)])
        ia, ib = np.interp(ta, tt, impulse), np.interp(tb, tt, impulse)
        return 2.0 * (ib - ia) / (RHO * V**3 * (tb**2 - ta**2))

    cf_imp = cf_between(f, t1, t2)
    t_mid = 0.5 * (t1 + t2)
    halves = (cf_between(f, t1, t_mid), cf_between(f, t_mid, t2))
    # the pressure part alone: -sum p l0 n_y over the face particles (normal (+-sin b, -cos b),
    # the apex's (0, -1)); the rest of the total is the contact (collision, viscous) part
    ny = np.where(np.abs(x) < 1e-12, 1.0, math.cos(beta))
    cf_press = cf_between((p * ny[None, :]).sum(axis=1) * float(d["l0"]), t1, t2)
    win = (t > t1) & (t <= t2 + 1e-12)
    cf_fit = float(np.sum(f[win] * t[win]) / np.sum(t[win] ** 2)) / (RHO * V**3)
    q = 0.5 * RHO * V**2
    c = cdot * t[win]
    xi = np.abs(x)[None, :] / c[:, None]
    cp = p[win] / q
    bins = np.floor(xi / BIN).astype(int).ravel()
    vals = cp.ravel()
    keep = bins < int(1.5 / BIN)
    sums = np.bincount(bins[keep], weights=vals[keep], minlength=int(1.5 / BIN))
    counts = np.bincount(bins[keep], minlength=int(1.5 / BIN))
    mean = np.divide(sums, counts, out=np.zeros_like(sums), where=counts > 0)
    k = int(np.argmax(mean))
    c_end = cdot * t2
    x0 = IMPULSE_XI * c_end
    pulses = []
    for side in (x > 0, x < 0):
        j = np.flatnonzero(side)[np.argmin(np.abs(np.abs(x[side]) - x0))]
        xj = abs(float(x[j]))
        pulses.append(float(np.sum(p[:, j] * dt)) / (RHO * V * math.sqrt(c_end**2 - xj**2)))
    cfw, cpw, cpz = wagner_cf(beta), wagner_cp_max(beta), ZF_CP_MAX.get(beta_deg, math.nan)
    cfm, cpm, cpb = mlm_cf(beta), mlm_cp_max(beta), mlm_cp_binned(beta)
    return {
        "beta_deg": beta_deg,
        "n": n,
        "l0": float(d["l0"]),
        "tank": tank,
        "variant": variant,
        "particles": int(d["particles"]),
        "steps": len(t),
        "wall_s": float(d["wall_s"]),
        "cf_impulse": cf_imp,
        "cf_fit": cf_fit,
        "cf_wagner": cfw,
        "cf_ratio": cf_imp / cfw,
        "cf_mlm": cfm,
        "cf_ratio_mlm": cf_imp / cfm,
        "cf_half1": halves[0],
        "cf_half2": halves[1],
        "cf_pressure": cf_press,
        "cp_max": float(mean[k]),
        "xi_peak": (k + 0.5) * BIN,
        "cp_spike": float(cp.max()),
        "cp_wagner": cpw,
        "cp_ratio_wagner": float(mean[k]) / cpw,
        "cp_mlm": cpm,
        "cp_mlm_bin": cpb,
        "cp_ratio_mlm_bin": float(mean[k]) / cpb,
        "cp_zf": cpz,
        "cp_ratio_zf": float(mean[k]) / cpz,
        "impulse_ratio": float(np.mean(pulses)),
    }


def observed_order(q: list[float]) -> float:
    """Order p from three values at spacings h, h/2, h/4: |q1 - q2| / |q2 - q3| = 2^p."""
    a, b = abs(q[0] - q[1]), abs(q[1] - q[2])
    return math.log2(a / b) if a > 0 and b > 0 else math.nan


def richardson(q: list[float]) -> float:
    """Richardson estimate from three values at h, h/2, h/4 when their changes are monotone and
    shrink (observed order p > 0): q3 + (q3 - q2) / (2^p - 1); NaN otherwise (no asymptotic
    range: extrapolating would be a guess)."""
    p = observed_order(q)
    mono = (q[0] - q[1]) * (q[1] - q[2]) > 0
    if not mono or not p > 0:
        return math.nan
    return q[2] + (q[2] - q[1]) / (2.0**p - 1.0)


def convergence_rows(rows: list[dict]) -> list[dict]:
    """One row per deadrise, quantity of :data:`CONVERGED` and three consecutive spacings of the
    study's set-up (tank 1, no variant): the values, changes, monotone or not, observed order,
    Richardson estimate, and the finest of the three over each reference."""
    out = []
    for b in sorted({r["beta_deg"] for r in rows}):
        rs = sorted(
            (r for r in rows if r["beta_deg"] == b and r["tank"] == 1.0 and not r["variant"]),
            key=lambda r: r["n"],
        )
        for k in range(len(rs) - 2):
            three = rs[k : k + 3]
            for key, refs in CONVERGED.items():
                qs = [r[key] for r in three]
                fin = three[2]
                ref = {
                    name: (fin[col] if col in refs else math.nan)
                    for name, col in (
                        ("wagner", "cf_wagner" if key == "cf_impulse" else "cp_wagner"),
                        ("mlm", "cf_mlm" if key == "cf_impulse" else "cp_mlm"),
                        ("mlm_bin", "cp_mlm_bin"),
                        ("zf", "cp_zf"),
                    )
                }
                out.append(
                    {
                        "beta_deg": b,
                        "quantity": key,
                        "n1": three[0]["n"],
                        "n2": three[1]["n"],
                        "n3": three[2]["n"],
                        "q1": qs[0],
                        "q2": qs[1],
                        "q3": qs[2],
                        "change12": qs[1] - qs[0],
                        "change23": qs[2] - qs[1],
                        "monotone": int((qs[0] - qs[1]) * (qs[1] - qs[2]) > 0),
                        "order": observed_order(qs),
                        "richardson": richardson(qs),
                        "finest": qs[2],
                        "ref_wagner": ref["wagner"],
                        "ref_mlm": ref["mlm"],
                        "ref_mlm_bin": ref["mlm_bin"],
                        "ref_zf": ref["zf"],
                        "finest_over_wagner": qs[2] / ref["wagner"],
                        "finest_over_mlm": qs[2] / ref["mlm"],
                        "finest_over_mlm_bin": qs[2] / ref["mlm_bin"],
                        "finest_over_zf": qs[2] / ref["zf"],
                    }
                )
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--betas", default="10,30")
    ap.add_argument("--levels", default="20,40,80")
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument(
        "--tank-levels",
        default="",
        help="also run beta 30 in a tank twice as wide and deep at these n (e.g. 20,40)",
    )
    ap.add_argument(
        "--variants",
        default="",
        help="also run beta 30 as variant:n pairs (dt05:40,gravity:40; VARIANTS)",
    )
    ap.add_argument("--analyse-only", action="store_true")
    args = ap.parse_args()
    os.environ.setdefault("NUMBA_NUM_THREADS", str(args.threads))
    betas = [int(b) for b in args.betas.split(",")]
    levels = [int(n) for n in args.levels.split(",")]
    cases = [(b, n, 1.0, "") for b in betas for n in levels]
    tank_levels = [int(n) for n in args.tank_levels.split(",")] if args.tank_levels else []
    runs = cases + [(30, n, 2.0, "") for n in tank_levels]
    extra = [v.split(":") for v in args.variants.split(",")] if args.variants else []
    runs += [(30, int(n), 1.0, v) for v, n in extra]
    if not args.analyse_only:
        for case in runs:
            run_case(*case)
    # tank checks and variants run before are reported too
    cases += [(30, n, 2.0, "") for n in levels]
    cases += [(30, n, 1.0, v) for v in VARIANTS if v for n in levels]
    rows = [analyse(*c) for c in cases if (OUT_DIR / f"{case_name(*c)}.npz").is_file()]
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from results_csv import write_csv

    write_csv(rows, CSV, COLUMNS, comment="validation/wedge_entry.py: rigid wedge entry, V = 5 m/s")
    head = f"{'beta':>4} {'n':>3} {'tank':>4}{'variant':>8} {'N':>6} {'steps':>5} {'wall s':>7} "
    head += f"{'CF imp':>7} {'CF fit':>7} {'CF Wag':>7} {'CF MLM':>7} {'Cpmax':>6} {'xi':>5} "
    head += f"{'spike':>7} {'CpWag':>6} {'CpMLM':>6} {'CpZF':>5} {'I/IWag':>6} "
    head += f"{'CF 1st/2nd half':>15} {'CF p':>6}"
    print(head)
    for r in rows:
        print(
            f"{r['beta_deg']:>4} {r['n']:>3} {r['tank']:>4g}{r['variant']:>8} {r['particles']:>6} "
            f"{r['steps']:>5} "
            f"{r['wall_s']:>7.0f} {r['cf_impulse']:>7.2f} {r['cf_fit']:>7.2f} "
            f"{r['cf_wagner']:>7.2f} {r['cf_mlm']:>7.2f} {r['cp_max']:>6.2f} "
            f"{r['xi_peak']:>5.3f} {r['cp_spike']:>7.1f} {r['cp_wagner']:>6.2f} "
            f"{r['cp_mlm']:>6.2f} {r['cp_zf']:>5.2f} "
            f"{r['impulse_ratio']:>6.3f} {r['cf_half1']:>7.1f}/{r['cf_half2']:<7.1f} "
            f"{r['cf_pressure']:>6.1f}"
        )
    conv = convergence_rows(rows)
    write_csv(
        conv,
        CONVERGENCE_CSV,
        CONVERGENCE_COLUMNS,
        comment="validation/wedge_entry.py: observed convergence over three spacings",
    )
    for c in conv:
        qs = (c["q1"], c["q2"], c["q3"])
        refs = ", ".join(
            f"{name} {c[f'finest_over_{name}']:.3f}"
            for name in ("wagner", "mlm", "mlm_bin", "zf")
            if not math.isnan(c[f"finest_over_{name}"])
        )
        print(
            f"beta {c['beta_deg']}, n = {c['n1']}-{c['n3']}: {c['quantity']} "
            f"{' -> '.join(f'{q:.4g}' for q in qs)} (changes {c['change12']:+.3g}, "
            f"{c['change23']:+.3g}), observed order {c['order']:.2f}"
            + (
                f", Richardson {c['richardson']:.4g}"
                if c["monotone"] and not math.isnan(c["richardson"])
                else " (not monotone: no asymptotic order)"
                if not c["monotone"]
                else " (monotone, changes not shrinking: no asymptotic range)"
            )
            + (f"; finest / reference: {refs}" if refs else "")
        )


if __name__ == "__main__":
    main()
