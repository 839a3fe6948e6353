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
observed orders, Newton iterations and wall time per load; the built-in immovable edge and
nu = 0.3 at n = 16 as sensitivities. Small-load anchor: w0 D / (q a^4) against 0.00126
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
