"""Oscillating drop in a central force field (references.md section 7; the seed paper's case):
δ-SPH against δ-SPHC, semi-axis against the ellipse ODE and the energy decay rate (issue 23).

A circular drop of radius R = 1 m (rho0 = 1000 kg/m^3, no gravity) in the body force
f = -Omega^2 r, Omega = 1/s, starts with u = sigma0 x, v = -sigma0 y, sigma0 = 1/s, and the
pressure p = rho0 (sigma0^2 + Omega^2)(R^2 - r^2) / 2 (Monaghan & Rafiee 2013; seed eqs. 14-15).
It stays an ellipse with semi-axes a(t), b(t): d sigma/dt = (sigma^2 + Omega^2)(b^2 - a^2) /
(a^2 + b^2), da/dt = sigma a, db/dt = -sigma b, integrated here with scipy (solve_ivp, rtol
1e-10). The drop's a(t) is measured from its second moment, a = 2 sqrt(<x^2>) (exact for a
uniformly filled ellipse), divided by the same measure of the initial lattice over R (the
lattice's own bias, 0.4 % at R/dx = 20). The mechanical energy E = sum m (|u|^2 + Omega^2 |r|^2)
/ 2 is conserved by the flow; E_per(t) = (E(0) - E(t)) / E(0) is the seed's decay rate.

Cases: R/dx = --resolution (default 20, the seed uses 50-200, too many for our shared cores),
alpha_s = h/dx = 1.3 and 2.0 (--ratios), artificial viscosity alpha = 0.02 (--alphas), gradient 'plain' (δ-SPH, seed eq. 6) and 'corrected' (δ-SPHC,
eq. 12), RK4, c0 = 10 max(U_max, sqrt(p_max / rho0)) from the ODE (seed eq. 1), over
--periods ODE periods. Writes validation/results/delta_sph_drop.csv (per case: RMS and largest
error of a/R against the ODE, E_per at the end, the decay rate per period, the run's wall
time) and validation/results/delta_sph_drop_series.csv (t, a_ode, a and E_per per case).

    python validation/delta_sph_drop.py [--resolution 20] [--periods 2] [--ratios 1.3,2.0]
                                        [--alphas 0.02] [--tag SUFFIX]
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np
from scipy.integrate import solve_ivp

sys.path.insert(0, str(Path(__file__).resolve().parent))
from results_csv import write_csv  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "validation" / "results"
R, SIGMA0, OMEGA, RHO0 = 1.0, 1.0, 1.0, 1000.0


def ellipse_rhs(_t, y):
    """(sigma, a, b)' of the drop (references.md section 7)."""
    s, a, b = y
    return [(s * s + OMEGA**2) * (b * b - a * a) / (a * a + b * b), s * a, -s * b]


def ode(t_end: float, t_eval=None):
    return solve_ivp(
        ellipse_rhs, (0.0, t_end), [SIGMA0, R, R], rtol=1e-10, atol=1e-12, t_eval=t_eval,
        dense_output=True,
    )  # fmt: skip


def ode_period() -> tuple[float, float]:
    """The ODE's period (time between maxima of a) and the largest speed sigma a on the rim."""
    sol = ode(30.0, np.linspace(0.0, 30.0, 300001))
    a = sol.y[1]
    peaks = np.flatnonzero((a[1:-1] > a[:-2]) & (a[1:-1] >= a[2:])) + 1
    u = np.max(np.abs(sol.y[0]) * np.maximum(sol.y[1], sol.y[2]))
    return float(np.diff(sol.t[peaks]).mean()), float(u)


def drop_solver(n_per_radius: int, ratio: float, gradient: str, c0: float, alpha: float = 0.02):
    from mpsfem.fluid_mps.geometry import ParticleSet
    from mpsfem.fluid_sph.solver import DeltaSPHSolver
    from mpsfem.scenario.fluid import FluidSection

    dx = R / n_per_radius
    spec = FluidSection(
        method="delta-sph",
        spacing=dx,
        density=RHO0,
        gravity=[0.0, 0.0],
        hydrostatic_start=False,
        blocks=[{"lower": [-R, -R], "upper": [R, R]}],
        domain_lower=[-3.0 * R, -3.0 * R],  # the drop stretches to a = 1.9 R (sigma0 = 1)
        domain_upper=[3.0 * R, 3.0 * R],
        time_step={"dt_max": 0.01},
        sph={
            "smoothing_ratio": ratio,
            "gradient": gradient,
            "sound_speed": c0,
            "central_field_omega": OMEGA,
            "integrator": "rk4",
            "viscosity_alpha": alpha,
        },
    )
    g = (np.arange(-n_per_radius, n_per_radius) + 0.5) * dx
    pos = np.stack(np.meshgrid(g, g, indexing="ij"), axis=-1).reshape(-1, 2)
    pos = np.ascontiguousarray(pos[np.hypot(pos[:, 0], pos[:, 1]) < R])
    ps = ParticleSet(pos, np.zeros_like(pos), np.zeros(len(pos), np.int8), np.zeros_like(pos),
                     len(pos))  # fmt: skip
    s = DeltaSPHSolver(spec, particles=ps)
    vel = np.c_[SIGMA0 * pos[:, 0], -SIGMA0 * pos[:, 1]]
    r2 = (pos**2).sum(axis=1)
    p = RHO0 * (SIGMA0**2 + OMEGA**2) * (R * R - r2) / 2.0  # references.md section 7
    s.set_initial_state(vel, p)
    return s


def semi_axis(s) -> float:
    x = s.pos[: s.n_fluid, 0]
    return 2.0 * math.sqrt(float(np.mean(x * x)))  # a = 2 sqrt(<x^2>) for a uniform ellipse


def energy(s) -> float:
    nf = s.n_fluid
    v2 = (s.vel[:nf] ** 2).sum()
    r2 = (s.pos[:nf] ** 2).sum()
    return 0.5 * s.mass * (v2 + OMEGA**2 * r2)


def run_case(n, ratio, gradient, c0, t_end, sample_dt, alpha):
    s = drop_solver(n, ratio, gradient, c0, alpha)
    a0 = semi_axis(s)
    e0 = energy(s)
    rows = [(0.0, R, 0.0)]
    tic = time.perf_counter()
    t_next = sample_dt
    while s.t < t_end - 1e-12:
        s.step(s.dt_towards(min(t_next, t_end)))
        if s.t >= t_next - 1e-12:
            rows.append((s.t, semi_axis(s) * R / a0, (e0 - energy(s)) / e0))
            t_next += sample_dt
    return np.array(rows), time.perf_counter() - tic, s


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--resolution", type=int, default=20, help="R / dx (default 20)")
    ap.add_argument("--periods", type=float, default=2.0, help="ODE periods to run (default 2)")
    ap.add_argument("--ratios", default="1.3,2.0", help="h / dx values (default 1.3,2.0)")
    ap.add_argument("--alphas", default="0.02", help="artificial viscosity alphas (default 0.02)")
    ap.add_argument("--tag", default="", help="suffix of the CSV names")
    args = ap.parse_args()
    period, u_max = ode_period()
    p_max = RHO0 * (SIGMA0**2 + OMEGA**2) * R * R / 2.0
    c0 = 10.0 * max(u_max, math.sqrt(p_max / RHO0))  # seed eq. 1
    t_end = args.periods * period
    print(
        f"ODE period {period:.4f} s, U_max {u_max:.4f} m/s, c0 = {c0:.3f} m/s, to t = {t_end:.3f}"
    )
    sol = ode(t_end)
    summary, series = [], {}
    grid = [
        (ratio, alpha, gradient)
        for ratio in (float(x) for x in args.ratios.split(","))
        for alpha in (float(x) for x in args.alphas.split(","))
        for gradient in ("plain", "corrected")
    ]
    for ratio, alpha, gradient in grid:
        rows, wall, s = run_case(args.resolution, ratio, gradient, c0, t_end, 0.05, alpha)
        a_ode = sol.sol(rows[:, 0])[1]
        err = rows[:, 1] - a_ode
        decay_per_period = rows[-1, 2] / args.periods
        name = f"{'delta-SPHC' if gradient == 'corrected' else 'delta-SPH'} h={ratio}dx a={alpha}"
        summary.append(
            {
                "case": name,
                "R_over_dx": args.resolution,
                "smoothing_ratio": ratio,
                "gradient": gradient,
                "viscosity_alpha": alpha,
                "particles": s.n_fluid,
                "steps": s.step_count,
                "c0": c0,
                "t_end": t_end,
                "rms_error_a_over_R": float(np.sqrt(np.mean(err**2))) / R,
                "max_error_a_over_R": float(np.abs(err).max()) / R,
                "E_per_end": float(rows[-1, 2]),
                "E_per_per_period": decay_per_period,
                "wall_time_s": wall,
            }
        )
        series[name] = (rows, a_ode)
        r = summary[-1]
        print(
            f"{name:22} a/R rms {r['rms_error_a_over_R']:.4f} max {r['max_error_a_over_R']:.4f}"
            f"  E_per(end) {r['E_per_end']:.4f} ({decay_per_period:.4f}/period)"
            f"  {s.step_count} steps {wall:.0f} s"
        )
    write_csv(
        summary,
        RESULTS / f"delta_sph_drop{args.tag}.csv",
        comment="oscillating drop, sigma0 = Omega = R = 1 (validation/delta_sph_drop.py): semi-axis "
        "error against the ODE and mechanical-energy decay E_per",
    )
    t = next(iter(series.values()))[0][:, 0]
    cols = {"t": t, "a_ode": next(iter(series.values()))[1]}
    for name, (rows, _) in series.items():
        cols[f"a {name}"] = rows[:, 1]
        cols[f"E_per {name}"] = rows[:, 2]
    write_csv(
        [dict(zip(cols, vals, strict=True)) for vals in zip(*cols.values(), strict=True)],
        RESULTS / f"delta_sph_drop{args.tag}_series.csv",
        comment="oscillating drop series: ODE semi-axis and each case's a/R and E_per",
    )
    print(f"wrote {RESULTS / f'delta_sph_drop{args.tag}.csv'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
