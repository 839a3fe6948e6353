"""Where the MPS load's step-to-step noise comes from: each step's pressure solve split by its
sources (issue 20, the ringing; docs/fluid.md, "What the ringing is").

An in-process re-run of a case of validation/delta_sph_obstacle.py (default ``mps20_stiff``:
the obstacle at L/20 with E = 2e11 Pa, a member that does not move) from 0.12 s to 0.25 s
(the impact) that books, after every fluid step of each window's last coupling iterate (the
accepted one where windows converge, as on the stiff plate):

- the member's pressure-integral force (thesis eq. 2-51, N/m) and its contact force;
- the linear pressure equation A p = b split by the parts of b (exact: their sum is b to
  round-off, checked): the velocity divergence's share (1 - gamma) rho / dt <div u*>, the
  number density's share gamma rho / dt^2 (n* - n0) / n0, and the known boundary values (the
  Neumann walls' ghosts and flux, the free surface's Dirichlet values), each solved on its own
  (sparse LU of the step's A); their means over three bands of non-surface fluid by distance
  to the member (near: < 1.5 l0; mid: 3-12 l0; far: > 12 l0, below y = 0.3 m), before the
  negative-pressure clamp, and the clamped pressure's mean there;
- over interior fluid (not flagged, no wall, member or flagged particle within 2.1 l0), the
  RMS of the MPS divergence (eq. 2-15) of u* (the source's), of the collision model's velocity
  change, of the pressure correction's velocity change, and of u^{n+1} after the correction
  (same pairs, the positions of the source), the share of u*'s divergence the correction
  leaves (the projection of div u^{n+1} on div u*), and the RMS of u*'s first-order consistent
  divergence (the moment matrix's inverse; exact for a linear velocity field), to tell
  particle-scale velocity noise from an error of the operator on a smooth flow.

Per case, a summary row (delta_sph_obstacle_pressure_split.csv): per band the means and the
RMS step-to-step jumps of each share and of the total, before and after the clamp; the
correlation of each share's jump with the total's; the member force's RMS step jump, its mean
and the lag-1 autocorrelation of its jumps (-0.5 for white noise); the divergence RMSs. A
diagnostic, not a results-file quantity: a few minutes a case on one thread.

    python validation/mps_pressure_split.py [--cases mps20_stiff ...] [--set KEY=VALUE ...]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
import scipy.sparse.linalg as spla
from scipy.spatial import cKDTree

sys.path.insert(0, str(Path(__file__).resolve().parent))
import delta_sph_obstacle as obstacle  # noqa: E402 - the cases and their in-process build
from results_csv import read_csv, write_csv  # noqa: E402

from mpsfem.fluid_mps import operators, probes  # noqa: E402
from mpsfem.fluid_mps.kernels import weight  # noqa: E402
from mpsfem.fluid_mps.particle_kinds import FLUID, STRUCTURE, STRUCTURE_DUMMY  # noqa: E402

CSV = obstacle.RESULTS / "delta_sph_obstacle_pressure_split.csv"
SPAN = (0.12, 0.25)  # s: the impact, the ringing's window
BANDS = {"near": (0.0, 1.5), "mid": (3.0, 12.0), "far": (12.0, np.inf)}  # x l0 from the member
SHARES = ("divergence", "density", "boundary")
TOP = 0.3  # m: the bands' fluid lies below (the tank's upper air is no part of the impact)


class StepRecorder:
    """Hooks on the MPS solver of ``fluid`` that book one row per fluid step after ``t0``."""

    def __init__(self, fluid, t0: float):
        self.s = fluid.solver
        self.ps = self.s.pressure
        self.t0 = t0
        self.rows: dict[float, list[float]] = {}  # step end time -> row (last iterate wins)
        self.pending: dict = {}
        self.members = [n for n in self.s._patch if n.startswith("obstacle")]
        self._hook()

    def _hook(self) -> None:
        s, ps = self.s, self.ps
        assemble, collision, correction, step = (
            ps.assemble, s._stage_collision, s._stage_correction, s.step,
        )  # fmt: skip

        def on_collision(nb, dt):
            self.pending["v0"] = s.vel.copy()
            moved = collision(nb, dt)
            self.pending["v1"] = s.vel.copy()
            self.pending["nb"] = nb
            return moved

        def on_assemble(pos, vel, kind, number_density, free_surface, nb, dt, extra=None, **kw):
            A, b, m = assemble(pos, vel, kind, number_density, free_surface, nb, dt, extra, **kw)
            if s.t >= self.t0:
                self.pending.update(self._split(A, b, m, number_density, extra, dt))
            return A, b, m

        def on_correction(nb, near, dt):
            self.pending["v2"] = s.vel.copy()
            self.pending["pos"] = s.pos.copy()
            correction(nb, near, dt)

        def on_step(dt):
            step(dt)
            if s.t >= self.t0 and "solutions" in self.pending:
                self.rows[round(s.t, 12)] = self._row(dt)
            self.pending.clear()

        ps.assemble, s._stage_collision = on_assemble, on_collision
        s._stage_correction, s.step = on_correction, on_step

    def _split(self, A, b, m, number_density, extra, dt) -> dict:
        """b's three parts on the unknown rows, each solved alone with the step's A."""
        ps = self.ps
        n = number_density.shape[0]
        unknown = np.nonzero(ps.unknown[:n] == 1)[0]
        rows = ps.row_of[unknown]
        parts = np.zeros((3, m))
        parts[0, rows] = -(1.0 - ps.gamma) * ps.rho / dt * ps.source_div[unknown]  # eq. 2-23
        parts[1, rows] = (
            ps.gamma
            * ps.rho
            / (dt * dt * ps.n0_density)
            * (number_density[unknown] - ps.n0_density)
        )  # eq. 2-23, number density
        if extra is not None:
            parts[2, rows] = extra[unknown]
        error = float(np.abs(parts.sum(axis=0) - b).max() / max(np.abs(b).max(), 1e-300))
        lu = spla.splu(A.tocsc())
        return {"solutions": [lu.solve(q) for q in parts], "unknown": unknown, "rows": rows,
                "split_error": error}  # fmt: skip

    def _row(self, dt: float) -> list[float]:
        s, pend = self.s, self.pending
        o = s.n_fluid
        force, contact = np.zeros(s.dim), np.zeros(s.dim)
        for name in self.members:
            pt = s._patch[name]
            force += probes.patch_force(s.p, s.normal, pt.start, pt.stop, s.kind, s.l0)
            contact += s.budget.contact_force[pt.start - o : pt.stop - o].sum(axis=0)
        pos = pend["pos"]
        flagged = s.free_surface[:o].astype(bool)
        member = pos[(s.kind == STRUCTURE) | (s.kind == STRUCTURE_DUMMY)]
        dist = cKDTree(member).query(pos[:o])[0] / s.l0
        row = [s.t, dt, force[0], contact[0], pend["split_error"]]
        unknown, rows = pend["unknown"], pend["rows"]
        fluid_rows = np.full(o, -1)
        is_fluid = unknown < o
        fluid_rows[unknown[is_fluid]] = rows[is_fluid]
        for lo, hi in BANDS.values():
            sel = (dist >= lo) & (dist < hi) & ~flagged & (pos[:o, 1] < TOP) & (fluid_rows >= 0)
            for q in pend["solutions"]:
                row.append(float(q[fluid_rows[sel]].mean()) if sel.any() else np.nan)
            row.append(float(s.p[:o][sel].mean()) if sel.any() else np.nan)  # clamped
        row += self._divergences(pend, pos, flagged)
        return row

    def _divergences(self, pend, pos, flagged) -> list[float]:
        """RMS over interior fluid of the divergence of u*, of the collision's and the
        correction's velocity changes, of u^{n+1}; the share of div u* left after the step."""
        s, ps, nb = self.s, self.ps, pend["nb"]
        o, n = s.n_fluid, len(s.kind)
        bad = np.nonzero((s.kind != FLUID) | np.r_[flagged, np.zeros(n - o, bool)])[0]
        clear = cKDTree(pos[bad]).query(pos[:o])[0] > ps.re_density
        interior = np.r_[clear & ~flagged & (pos[:o, 1] < TOP), np.zeros(n - o, bool)]
        out = np.empty(n)

        def div(u: np.ndarray) -> np.ndarray:
            operators.divergence(pos, u, s.kind, nb.indptr, nb.indices, ps.re_density,
                                 s.wcode, ps.n0_density, out, True)  # fmt: skip
            return out[interior].copy()

        star, kick = div(pend["v2"]), div(pend["v1"] - pend["v0"])
        consistent = corrected_divergence(
            pos, pend["v2"], np.nonzero(interior)[0], nb, ps.re_density, s.wcode
        )
        corr, after = div(s.vel - pend["v2"]), div(s.vel)
        rms = lambda x: float(np.sqrt(np.mean(x**2))) if x.size else np.nan  # noqa: E731
        left = float(np.dot(after, star) / np.dot(star, star)) if star.size else np.nan
        return [rms(star), rms(kick), rms(corr), rms(after), left, float(interior.sum()),
                rms(consistent)]  # fmt: skip


def corrected_divergence(pos, vel, index, nb, re: float, wcode: int) -> np.ndarray:
    """The first-order consistent divergence tr(C_i^-1 sum_j (u_j - u_i) (x) r_ij w_ij / r_ij^2),
    C_i = sum_j r_ij (x) r_ij w_ij / r_ij^2 (exact for a linear velocity field, 1/s) of
    particles ``index`` over their neighbours within ``re`` (m): every kind counts, so pass
    particles whose neighbours there are all fluid (the interior of :meth:`_divergences`)."""
    counts = nb.indptr[index + 1] - nb.indptr[index]
    owner = np.repeat(np.arange(index.size), counts)
    cols = np.concatenate([nb.indices[nb.indptr[i] : nb.indptr[i + 1]] for i in index])
    r = pos[cols] - pos[index[owner]]
    r2 = np.einsum("ij,ij->i", r, r)
    keep = (r2 > 0.0) & (r2 < re * re)
    owner, cols, r, r2 = owner[keep], cols[keep], r[keep], r2[keep]
    w = np.array([weight(np.sqrt(x), re, wcode) for x in r2]) / r2
    du = vel[cols] - vel[index[owner]]
    moment = np.zeros((index.size, pos.shape[1], pos.shape[1]))
    grad = np.zeros_like(moment)
    np.add.at(moment, owner, r[:, :, None] * r[:, None, :] * w[:, None, None])
    np.add.at(grad, owner, du[:, :, None] * r[:, None, :] * w[:, None, None])
    return np.einsum("kab,kba->k", grad, np.linalg.inv(moment))


def summarise(key: str, table: np.ndarray) -> dict:
    """The summary row of one case from its per-step table (:meth:`StepRecorder._row`)."""
    t0, t1 = SPAN
    table = table[(table[:, 0] > t0) & (table[:, 0] <= t1)]

    def jump(x: np.ndarray) -> float:
        d = np.diff(x)
        return float(np.sqrt(np.nanmean(d**2)))

    force = table[:, 2]
    dforce = np.diff(force)
    out = {
        "case": key,
        "steps": int(len(table)),
        "dt_mean_s": float(table[:, 1].mean()),
        "split_error_max": float(table[:, 4].max()),
        "force_mean": float(force.mean()),
        "force_step_jump_rms": jump(force),
        "force_jump_lag1": float(np.corrcoef(dforce[:-1], dforce[1:])[0, 1]),
        "contact_mean": float(table[:, 3].mean()),
        "contact_step_jump_rms": jump(table[:, 3]),
    }
    col = 5
    for band in BANDS:
        shares = table[:, col : col + 3]
        total = shares.sum(axis=1)
        dtotal = np.diff(total)
        for k, name in enumerate(SHARES):
            d = np.diff(shares[:, k])
            ok = np.isfinite(d) & np.isfinite(dtotal)
            out[f"{band}_{name}_mean"] = float(np.nanmean(shares[:, k]))
            out[f"{band}_{name}_jump"] = jump(shares[:, k])
            out[f"{band}_{name}_jump_corr"] = float(np.corrcoef(d[ok], dtotal[ok])[0, 1])
        out[f"{band}_solved_mean"] = float(np.nanmean(total))
        out[f"{band}_solved_jump"] = jump(total)
        out[f"{band}_clamped_mean"] = float(np.nanmean(table[:, col + 3]))
        out[f"{band}_clamped_jump"] = jump(table[:, col + 3])
        col += 4
    names = ("div_ustar", "div_collision", "div_correction", "div_after", "div_left_share")
    for k, name in enumerate(names):
        out[f"interior_{name}"] = float(np.nanmedian(table[:, col + k]))
    out["interior_particles"] = float(np.mean(table[:, col + 5]))
    out["interior_div_ustar_corrected"] = float(np.nanmedian(table[:, col + 6]))
    return out


def run_case(key: str, sets: list[str]) -> dict:
    """Re-run case ``key`` in process to the end of :data:`SPAN` and summarise it."""
    method, n, _, *extra = obstacle.CASES[key]
    if method != "mps":
        raise SystemExit(f"{key}: the split is of the MPS pressure equation (case is {method})")
    extra = tuple(extra[0]) if extra else ()
    sc = obstacle.overrides(n, SPAN[1], (*extra, *sets))
    fluid, scheme, _ = obstacle.coupled_in_process(obstacle.MPS_SCENARIO, sc)
    recorder = StepRecorder(fluid, SPAN[0])
    while scheme.t < SPAN[1] - 1e-9:
        scheme.advance_window()
    table = np.array([recorder.rows[t] for t in sorted(recorder.rows)])
    row = summarise(key if not sets else f"{key}+{'+'.join(sets)}", table)
    return row


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", nargs="+", default=["mps20_stiff"], choices=list(obstacle.CASES))
    ap.add_argument("--set", dest="sets", action="append", default=[], help="extra override")
    args = ap.parse_args(argv)
    rows = read_csv(CSV) if CSV.exists() else []
    for key in args.cases:
        row = run_case(key, args.sets)
        rows = [r for r in rows if r["case"] != row["case"]] + [row]
        print(
            f"{row['case']}: force mean {row['force_mean']:.0f} N/m, step jump "
            f"{row['force_step_jump_rms']:.0f} (lag-1 {row['force_jump_lag1']:.2f}); near plate "
            f"solved {row['near_solved_mean']:.0f} Pa (jump {row['near_solved_jump']:.0f}), "
            f"clamped {row['near_clamped_mean']:.0f} ({row['near_clamped_jump']:.0f}); "
            f"div u* {row['interior_div_ustar']:.2f} 1/s, left {row['interior_div_left_share']:.2f}"
        )
    write_csv(
        rows,
        CSV,
        comment="MPS pressure solve split by its sources per step over the impact 0.12-0.25 s "
        "(validation/mps_pressure_split.py); pressures Pa, forces N/m, divergences 1/s",
    )


if __name__ == "__main__":
    main()
