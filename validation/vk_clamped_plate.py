"""Clamped square von Karman plate under uniform pressure against Levy's large-deflection series
(issue 21, "Tests").

Reference: Levy, S. (1942) "Square plate with clamped edges under normal pressure producing large
deflections", NACA TN 847 / NACA Report 740, Table 5: centre deflection w0 / h against the load
parameter Q = q a^4 / (E h^4) for a square plate of side a, Poisson's ratio nu = 0.316, edges
clamped against rotation and against displacement normal to the edge but free to slide along it
(the report's summary: the supports "clamp the plate rigidly against rotations and displacements
normal to the edge but ... permit displacements parallel to the edge"). Levy solves the von
Karman equations with truncated double Fourier series (the edge moments replaced by an
equivalent pressure on his simply supported solution, TN 846); his small-deflection results
equal Hencky's exactly, and the summary estimates the possible error of the truncated series as
"less than _ percent" (the digit is lost in the only text copy found) and quotes agreement
within 5 percent with Way's approximate solution. The table (:data:`LEVY_Q`, :data:`LEVY_W`) is
taken as transcribed, with "Table 5" and nu = 0.316, in the von Karman BEM scripts of a public
Julia repository (``scripts/plates/tran2015/run_static.jl`` and a Levy-plate script beside it,
found by the table's digits; the report itself was not readable here). Levy's table ends at
w0 / h = 1.902 ("centre deflections up to 1.9 times the plate thickness"): nothing beyond
w/h = 2 is compared, and no published value beyond it was found.

Set-up: a = 1 m, h = 0.01 m, E = 1e6 Pa (only Q and nu matter), the whole plate on n x n BFS
cells (the section schema has no symmetry conditions for a quarter plate); Levy's in-plane
support is the built-in ``clamped`` edge (w, grad w, u, v held) with the tangential in-plane
displacement released (:func:`clamped_plate`, ``inplane="levy"``); ``inplane="immovable"`` is
the built-in edge itself. The loads rise through Levy's values, each solved by full Newton
(:func:`mpsfem.structure_fem.newton.newton_solve`, the Jacobian re-formed every iteration) from
the previous load's solution, to a residual of 1e-10 of the load.

Writes validation/results/vk_clamped_plate.csv: per load, Levy's w0 / h, ours at each mesh, the
relative error of the finest mesh and of the Richardson extrapolation of the three finest, the
observed orders, Newton iterations and wall time per load; an independent spectral Ritz
solution of the same von Karman problem (:func:`ritz_centre_deflection`, K = 6, 8, 10) and the
finite elements' difference to it; the built-in immovable edge and nu = 0.3 at n = 16 as
sensitivities. Small-load anchor: w0 D / (q a^4) against 0.00126
(T & W-K 1959, Table 35; 0.001265 to four digits).

    python validation/vk_clamped_plate.py [--meshes 4,8,16,32]
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from results_csv import write_csv  # noqa: E402

from mpsfem.structure_fem.newton import TangentFactor, newton_solve  # noqa: E402
from mpsfem.structure_fem.von_karman_plate import VonKarmanPlateModel  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
CSV = ROOT / "validation" / "results" / "vk_clamped_plate.csv"

#: Levy 1942, NACA Report 740 Table 5 (nu = 0.316): Q = q a^4 / (E h^4) and w0 / h
LEVY_Q = (17.79, 38.3, 63.4, 95.0, 134.9, 184.0, 245.0, 318.0, 402.0)
LEVY_W = (0.237, 0.471, 0.695, 0.912, 1.121, 1.323, 1.521, 1.714, 1.902)
LEVY_NU = 0.316
#: linear clamped square plate, w0 = alpha q a^4 / D (/work/shared/references.md; T & W-K 1959
#: Table 35 prints 0.00126, the same value cut to three digits; Levy's small-load limit)
HENCKY_ALPHA = 0.001265
A, H, E = 1.0, 0.01, 1.0e6  # m, m, Pa
TOLERANCE = 1e-10  # Newton: |residual| <= TOLERANCE x (|f_int| + |load|)
#: Ritz check: Legendre degrees below 2 K a direction (K = 8: 1e-7 of w0, K = 10 the reference)
RITZ_ORDERS = (6, 8, 10)


def clamped_plate(n: int, nu: float = LEVY_NU, inplane: str = "levy") -> tuple:
    """(model, free dofs) of the clamped a x a von Karman plate on n x n cells. ``inplane``:
    "levy" holds only the in-plane displacement normal to each edge (Levy 1942: the edge slides
    along itself), "immovable" the built-in clamped edge (u = v = 0)."""
    if inplane not in ("levy", "immovable"):
        raise ValueError(f'inplane = {inplane!r}: "levy" or "immovable"')
    m = VonKarmanPlateModel.create(
        name="levy", element="bfs", E=E, nu=nu, density=1.0, thickness=H,
        bcs=["clamped"] * 4, rectangle=(A, A, n, n),
    )  # fmt: skip
    if inplane == "levy":
        fixed = [m.fixed[m.fixed < m.Nw]]  # the bending supports as built
        # edges in the order v = 0, u = a, v = b, u = 0: hold the normal component only
        for facets, comp in zip(m.edge_facets, ("u^2", "u^1", "u^2", "u^1"), strict=True):
            dofs = m.bm.get_dofs(facets=np.asarray(facets)).all(comp)
            fixed.append(m.Nw + np.asarray(dofs, dtype=np.int64))
        m.fixed = np.unique(np.concatenate(fixed)).astype(np.int64)
    return m, np.setdiff1d(np.arange(m.n_dof), m.fixed)


def load_path(model, free: np.ndarray, loads) -> list[tuple[float, float, int, float]]:
    """Static solutions at the load parameters ``loads`` (Q = q a^4 / (E h^4), rising), each by
    full Newton from the previous one: [(Q, w0 / h, Newton iterations, wall time s)]."""
    unit = model.pressure_load(E * H**4 / A**4)[free]  # the load of Q = 1
    probe = model.bw.probes(np.array([[A / 2], [A / 2]])).tocsr()
    q = np.zeros(model.n_dof)

    def full(x):
        q[free] = x
        return q

    def jacobian(x):
        return model.reduced_tangent(full(x), free)[1]

    out = []
    x = np.zeros(len(free))
    for Q in loads:
        t0 = time.perf_counter()
        F = Q * unit

        def residual(y, F=F):
            fi = model.internal_force(full(y))[free]
            scale = math.sqrt(fi @ fi) + math.sqrt(F @ F)
            return fi - F, scale, 0.0

        res = newton_solve(
            residual, jacobian, x, tangent=TangentFactor(), key=Q, tolerance=TOLERANCE,
            max_iterations=30, reuse_ratio=0.0,
            failure=lambda *a, Q=Q: f"clamped plate: Newton failed at Q = {Q}",
        )  # fmt: skip
        x = res.x
        w0 = float((probe @ full(x)[: model.Nw])[0]) / H
        out.append((Q, w0, res.iterations, time.perf_counter() - t0))
    return out


def ritz_centre_deflection(
    K: int, loads, nu: float = LEVY_NU, inplane: str = "levy"
) -> list[tuple[float, float, int]]:
    """Independent check of the finite elements: a spectral Ritz solution of the same von Karman
    energy (own code, dense numpy), doubly symmetric fields on s = 2x/a - 1, t = 2y/a - 1:
    w = sum (1-s^2)^2 (1-t^2)^2 P_2i(s) P_2j(t) (clamped), u = sum (1-s^2) P_2i+1(s) P_2j(t)
    (u = 0 on x = 0, a; times (1-t^2) for "immovable"), v the mirror image, i, j < K; Gauss
    quadrature exact for the quartic membrane energy; full Newton on the exact Hessian from the
    previous load. Energy (T & W-K 1959 eqs. 219-220 and sec. 10): 1/2 int N : eps + bending -
    q w. Returns [(Q, w0 / h, Newton iterations)]; converges spectrally (K = 8: 1e-7)."""
    from numpy.polynomial import legendre

    nq = 4 * K + 10  # Gauss points a direction: exact to degree 8 K + 19 > the energy's
    s, ws = legendre.leggauss(nq)
    J = 2.0 / A  # ds/dx

    def family(bubble, degrees):  # (k, derivative 0..2 in x, point) of bubble(s) P_k(s)
        b0, b1, b2 = bubble
        out = []
        for k in degrees:
            c = np.eye(k + 1)[k]
            p0, p1, p2 = (legendre.legval(s, legendre.legder(c, m)) for m in (0, 1, 2))
            out.append((b0 * p0, (b1 * p0 + b0 * p1) * J, (b2 * p0 + 2 * b1 * p1 + b0 * p2) * J**2))
        return np.array(out)

    zero, one = 0.0 * s, 1.0 + 0.0 * s
    clamp = ((1 - s**2) ** 2, -4 * s * (1 - s**2), -4 + 12 * s**2)
    held = (1 - s**2, -2 * s, -2 + zero)
    even, odd = range(0, 2 * K, 2), range(1, 2 * K, 2)
    Fw, Fn = family(clamp, even), family(held, odd)  # w; u along x (odd, zero at x edges)
    Ft = family(held if inplane == "immovable" else (one, zero, zero), even)  # u along y

    def tens(Fx, Fy, dx, dy):  # (point, basis) values of d^dx/dx^dx d^dy/dy^dy Fx_i(x) Fy_j(y)
        return np.einsum("ip,jq->pqij", Fx[:, dx], Fy[:, dy]).reshape(nq * nq, -1)

    wt = np.outer(ws, ws).ravel() / J**2  # quadrature weights (m^2)
    Bx, By, B0 = tens(Fw, Fw, 1, 0), tens(Fw, Fw, 0, 1), tens(Fw, Fw, 0, 0)
    Bxx, Byy, Bxy = tens(Fw, Fw, 2, 0), tens(Fw, Fw, 0, 2), tens(Fw, Fw, 1, 1)
    Ux, Uy = tens(Fn, Ft, 1, 0), tens(Fn, Ft, 0, 1)
    Vx, Vy = tens(Ft, Fn, 1, 0), tens(Ft, Fn, 0, 1)  # v(x, y) = u(y, x)
    nw, nm = Bx.shape[1], Ux.shape[1]
    n = nw + 2 * nm
    sw, su, sv = slice(0, nw), slice(nw, nw + nm), slice(nw + nm, n)
    D = E * H**3 / (12 * (1 - nu**2))
    lap = Bxx + Byy
    W = wt[:, None]
    # D int [(lap w)^2 - 2 (1 - nu) (w_xx w_yy - w_xy^2)] (T & W-K 1959 sec. 10)
    Kb = D * (
        lap.T @ (W * lap)
        - (1 - nu) * (Bxx.T @ (W * Byy) + Byy.T @ (W * Bxx) - 2 * Bxy.T @ (W * Bxy))
    )
    Cm = E * H / (1 - nu**2) * np.array([[1, nu, 0], [nu, 1, 0], [0, 0, (1 - nu) / 2]])
    centre = np.outer(*[[legendre.legval(0.0, np.eye(k + 1)[k]) for k in even]] * 2).ravel()
    c = np.zeros(n)
    out = []
    for Q in loads:
        F = np.zeros(n)
        F[sw] = Q * E * H**4 / A**4 * (B0.T @ wt)
        for it in range(51):  # noqa: B007 - the count is returned
            a = c[sw]
            wx, wy = Bx @ a, By @ a
            # eps = (u_x + wx^2/2, v_y + wy^2/2, u_y + v_x + wx wy) (T & W-K eq. 220)
            e = np.stack([Ux @ c[su] + 0.5 * wx**2, Vy @ c[sv] + 0.5 * wy**2,
                          Uy @ c[su] + Vx @ c[sv] + wx * wy])  # fmt: skip
            N = Cm @ e  # (N_xx, N_yy, N_xy), N/m
            Jm = np.zeros((3, nq * nq, n))  # d eps / d c
            Jm[0, :, sw], Jm[0, :, su] = wx[:, None] * Bx, Ux
            Jm[1, :, sw], Jm[1, :, sv] = wy[:, None] * By, Vy
            Jm[2, :, sw] = wy[:, None] * Bx + wx[:, None] * By
            Jm[2, :, su], Jm[2, :, sv] = Uy, Vx
            r = np.einsum("kpn,kp->n", Jm, N * wt) - F
            r[sw] += Kb @ a
            if np.linalg.norm(r) <= TOLERANCE * np.linalg.norm(F):
                break
            Hs = np.einsum("kpm,kpn->mn", Jm, np.einsum("kl,lpn->kpn", Cm, Jm) * W[None])
            Nw = N * wt
            Hs[sw, sw] += Kb + Bx.T @ (Nw[0][:, None] * Bx) + By.T @ (Nw[1][:, None] * By)
            Hs[sw, sw] += Bx.T @ (Nw[2][:, None] * By) + By.T @ (Nw[2][:, None] * Bx)
            c -= np.linalg.solve(Hs, r)
        else:
            raise RuntimeError(f"Ritz check: Newton did not converge at Q = {Q}")
        out.append((Q, float(centre @ c[sw]) / H, it))
    return out


def observed_order(w1: float, w2: float, w3: float) -> float:
    """Order p from three meshes halving the cell size: (w2 - w1) / (w3 - w2) = 2^p."""
    return math.log2(abs(w2 - w1) / abs(w3 - w2))


def richardson(w2: float, w3: float, p: float) -> float:
    """Extrapolation of the two finest meshes with order p."""
    return w3 + (w3 - w2) / (2.0**p - 1.0)


def linear_coefficient(n: int, Q: float = 1e-3) -> float:
    """w0 D / (q a^4) at a load so small that membrane action is negligible (w0 ~ 1e-5 h)."""
    m, free = clamped_plate(n)
    w0 = load_path(m, free, [Q])[0][1] * H
    D = E * H**3 / (12.0 * (1.0 - LEVY_NU**2))
    return w0 * D / (Q * E * H**4)


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--meshes", default="4,8,16,32", help="cells per side, each twice the last")
    args = ap.parse_args(argv)
    meshes = [int(s) for s in args.meshes.split(",")]
    runs = {}
    for n in meshes:
        t0 = time.perf_counter()
        runs[n] = load_path(*clamped_plate(n), LEVY_Q)
        print(f"n = {n}: {time.perf_counter() - t0:.1f} s")
    t0 = time.perf_counter()
    ritz = {K: ritz_centre_deflection(K, LEVY_Q) for K in RITZ_ORDERS}
    print(f"Ritz check, K = {RITZ_ORDERS}: {time.perf_counter() - t0:.1f} s")
    n_ref = 16 if 16 in meshes else meshes[-1]
    immovable = load_path(*clamped_plate(n_ref, inplane="immovable"), LEVY_Q)
    nu03 = load_path(*clamped_plate(n_ref, nu=0.3), LEVY_Q)
    rows = []
    for k, (Q, wl) in enumerate(zip(LEVY_Q, LEVY_W, strict=True)):
        row = {"Q": Q, "levy_w_h": wl}
        for n in meshes:
            row[f"w_h_n{n}"] = runs[n][k][1]
        fin = meshes[-1]
        row[f"err_n{fin}_pct"] = 100.0 * (runs[fin][k][1] - wl) / wl
        if len(meshes) >= 3:
            w1, w2, w3 = (runs[n][k][1] for n in meshes[-3:])
            p = observed_order(w1, w2, w3)
            row["order_finest3"] = p
            row["err_extrapolated_pct"] = 100.0 * (richardson(w2, w3, p) - wl) / wl
        if len(meshes) >= 4:
            row["order_coarsest3"] = observed_order(*(runs[n][k][1] for n in meshes[:3]))
        for n in meshes:
            row[f"newton_its_n{n}"] = runs[n][k][2]
            row[f"time_s_n{n}"] = runs[n][k][3]
        for K in RITZ_ORDERS:
            row[f"w_h_ritz_K{K}"] = ritz[K][k][1]
        w_ritz = ritz[RITZ_ORDERS[-1]][k][1]
        row["err_ritz_pct"] = 100.0 * (w_ritz - wl) / wl
        for n in meshes:
            row[f"fe_n{n}_minus_ritz_rel"] = (runs[n][k][1] - w_ritz) / w_ritz
        row[f"w_h_immovable_n{n_ref}"] = immovable[k][1]
        row[f"err_immovable_n{n_ref}_pct"] = 100.0 * (immovable[k][1] - wl) / wl
        row[f"w_h_nu0.3_n{n_ref}"] = nu03[k][1]
        row[f"err_nu0.3_n{n_ref}_pct"] = 100.0 * (nu03[k][1] - wl) / wl
        rows.append(row)
        print(", ".join(f"{c} {v:.5g}" if isinstance(v, float) else f"{c} {v}"
                        for c, v in row.items()))  # fmt: skip
    alphas = {n: linear_coefficient(n) for n in meshes[:3]}
    for n, al in alphas.items():
        print(f"small load, n = {n}: w0 D / (q a^4) = {al:.7f} (reference {HENCKY_ALPHA})")
    write_csv(
        rows, CSV,
        comment="validation/vk_clamped_plate.py: clamped square von Karman plate, centre "
        "deflection against Levy 1942 (NACA R-740 Table 5, nu = 0.316); small-load "
        + ", ".join(f"n{n} w0 D/(q a^4) = {al:.7f}" for n, al in alphas.items()),
    )  # fmt: skip
    print(f"wrote {CSV.relative_to(ROOT)}")


if __name__ == "__main__":
    main()
