"""Why the light plate's wet windows stall: per-iteration histories and the MPS force map's
response to small interface motions (issue 21, task H1).

Continues a light-plate run (validation/bottom_slamming_light.py) from a checkpoint in process,
steps its windows to ``--to``, then for ``--windows`` windows records every iteration's
residual, fictitious force error, and the change of the structure's load between iterates;
and, from the start of the last of them, probes the fluid window as a map x -> F: the same
iterate twice (determinism), then x + eps w for interface shapes w (rigid heave of the wetted
nodes, their first and a short sine) and eps from 1e-9 to 1e-6 m, giving the added mass the
MPS window presents along w,

    m_w(eps) = -(w . (F(x + eps w) - F(x))) / (|w|^2 delta_a),  delta_a = gamma eps / (beta T^2)

(delta_a: the change of the window's mean wall acceleration (s - v_n) / T, what the fluid
sees: the coupler interpolates the velocity linearly over the window; beta = 1/4, gamma = 1/2),
against the potential-flow operator's w M_a w / |w|^2 (structure_fem.added_mass_potential) on
the same nodes. A smooth map gives m_w independent of eps; jumps from particle-level switching
give m_w growing as eps falls. Writes validation/results/bottom_slamming_light_iterations.csv
(iterations; its ``iteration`` counts on across the recorded windows of a run) and
bottom_slamming_light_map.csv (the probe).

    python validation/bottom_slamming_light_iterations.py --restart FILE.ckpt.h5 \\
        --mf 0.5 --mf-model potential_flow --to 1.64 --windows 2
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bottom_slamming import DEPTH, RESULTS_DIR, SCENARIOS, Case, case_overrides, spacing_for  # noqa: E402
from bottom_slamming_light import light_overrides  # noqa: E402
from results_csv import read_csv, write_csv  # noqa: E402

from mpsfem.coupler.coupling_scheme import create_scheme  # noqa: E402
from mpsfem.fluid_methods import create_fluid_participant  # noqa: E402
from mpsfem.results.checkpoint import read_checkpoint  # noqa: E402
from mpsfem.scenario.loader import load_scenario  # noqa: E402
from mpsfem.simulation import (  # noqa: E402
    _join_state,
    _load_structure_state,
    coupling_config,
    member_nodes,
)
from mpsfem.structure_fem.added_mass_potential import patch_added_mass, patch_coordinates  # noqa: E402
from mpsfem.structure_fem.fictitious_mass import node_runs, wet_nodes  # noqa: E402
from mpsfem.structure_fem.participant import StructureParticipant  # noqa: E402

ITER_CSV = RESULTS_DIR / "bottom_slamming_light_iterations.csv"
MAP_CSV = RESULTS_DIR / "bottom_slamming_light_map.csv"
#: task H3 (after the crest): every iteration / every window of a stretch (``--record-to``)
CREST_ITER_CSV = RESULTS_DIR / "bottom_slamming_light_crest_iterations.csv"
CREST_CSV = RESULTS_DIR / "bottom_slamming_light_crest_windows.csv"
COMMENT = (
    "validation/bottom_slamming_light_iterations.py: per-iteration histories / the MPS "
    "window's force map of the light plate (issue 21, task H1)"
)


def build(args):
    case = Case(0.3, 0.06)
    spacing = spacing_for(float(args.l0), DEPTH)
    ft = args.force_tolerance
    overrides = (
        case_overrides("elastic", case, spacing)
        + light_overrides(
            args.mf, 1e-3, "displacement", 30, ft, None, args.mf_model, args.wet_pressure
        )
        + list(getattr(args, "set", None) or [])
    )
    loaded = load_scenario(SCENARIOS["elastic"], overrides)
    sc = loaded.scenario
    config = coupling_config(sc, None)
    members = member_nodes(sc)
    st = StructureParticipant(
        sc.structure, base_dir=loaded.path.parent, fluid_density=sc.fluid.density
    )
    mesh = st.interface()
    fluid = create_fluid_participant(
        sc.fluid, mesh, base_dir=loaded.path.parent, member_names=[m for m, _ in members]
    )
    scheme = create_scheme(fluid, st, config, log=lambda m: None)
    scheme.initialize()
    arrays, meta, _ = read_checkpoint(args.restart)
    fluid.load_state(_join_state(arrays["fluid"], meta["fluid"]))
    fluid.solver.load_preconditioner_arrays(
        arrays.get("fluid_preconditioner", {}), meta.get("fluid_preconditioner")
    )
    _load_structure_state(st, _join_state(arrays["structure"], meta["structure"]))
    scheme.load_state_dict(_join_state(arrays["scheme"], meta["scheme"]))
    return scheme, fluid, st, mesh, sc


def instrument(scheme, st, rows, window_index):
    """Record each iteration of the scheme's windows into ``rows``."""
    orig_f, orig_s, orig_it = scheme._fluid_window, scheme._structure_window, st.set_iterate
    state = {"x": None, "F": None, "k": 0}

    def set_iterate(x, T):
        state["x"] = np.array(x)
        orig_it(x, T)

    def fluid_window(*a):
        F, n = orig_f(*a)
        return F, n

    def structure_window(t0, t1, F1):
        d, v, n = orig_s(t0, t1, F1)
        k = state["k"] = state["k"] + 1
        x = state["x"]
        got = st.fictitious_force_error()
        dF = math.nan if state["F"] is None else float(np.linalg.norm(F1 - state["F"]))
        rows.append(
            {
                "window": window_index[0],
                "t_end": t1,
                "iteration": k,
                "residual_rms_m": float(np.sqrt(np.mean((d - x) ** 2))),
                "x_rms_m": float(np.sqrt(np.mean(x**2))),
                "force_error_rms": math.nan if got is None else got[0],
                "load_scale_rms": math.nan if got is None else got[1],
                "load_norm": float(np.linalg.norm(F1)),
                "load_change_norm": dF,
                "wet_nodes": int(st.fictitious_nodes.sum()),
            }
        )
        state["F"] = F1.copy()
        return d, v, n

    scheme._fluid_window, scheme._structure_window = fluid_window, structure_window
    st.set_iterate = set_iterate
    return state


def record_stretch(scheme, st, mesh, t_to: float, tag: str) -> tuple[list[dict], list[dict]]:
    """Step the windows to ``t_to`` recording every iteration (task H3): the relative
    displacement residual, the force error / load (the coupler's ratio), Aitken's factor the
    iterate was made with, the wet set (nodes, separate runs of nodes; nodes the iterate's own
    forces wet above the threshold), the interface load split into push (up) and suction (down)
    and the mid-span; per window the iterations, acceptance, the accepted iterate's wet-set
    nodes that its forces leave dry (they hold M_f without water), and the geometric mean
    contraction of the force ratio over the window's iterations."""
    pts = np.asarray(mesh.points)
    mid = int(np.argmin(np.abs(pts[:, 0] - 0.5 * (pts[0, 0] + pts[-1, 0]))))
    thr = st._fm_threshold  # N per node (wet pressure x tributary length); None: any load
    orig_s, orig_it = scheme._structure_window, st.set_iterate
    it_rows: list[dict] = []
    state = {"x": None, "k": 0, "window": scheme.index}

    def set_iterate(x, T):
        state["x"] = np.array(x)
        orig_it(x, T)

    def structure_window(t0, t1, F1):
        d, v, n = orig_s(t0, t1, F1)
        state["k"] += 1
        x = state["x"]
        got = st.fictitious_force_error()
        ratio = (
            math.nan
            if got is None
            else scheme.force_criterion.measure(*got, peak=scheme.force_scale_peak)
        )
        wet = st.fictitious_nodes
        mag = np.linalg.norm(F1, axis=1)
        own = mag > (0.0 if thr is None else thr)
        fy = F1[:, 1]
        it_rows.append(
            {
                "run": tag,
                "window": state["window"],
                "t_end": t1,
                "iteration": state["k"],
                "residual_rel": scheme.criterion.measure(x, d, scheme.d)[0],
                "force_ratio": ratio,
                "omega": float(getattr(scheme.acceleration, "omega", math.nan)),
                "wet_nodes": int(wet.sum()),
                "wet_runs": len(node_runs(pts, wet)),
                "iterate_wet_nodes": int(own.sum()),
                "iterate_wet_runs": len(node_runs(pts, own)),
                "push_n_per_m": float(fy[fy > 0].sum()),
                "suction_n_per_m": float(fy[fy < 0].sum()),
                "mid_mm": float(d[mid, 1]) * 1e3,
            }
        )
        return d, v, n

    scheme._structure_window, st.set_iterate = structure_window, set_iterate
    win_rows: list[dict] = []
    tic = time.perf_counter()
    while scheme.t < t_to - 1e-9:
        state["window"], state["k"] = scheme.index, 0
        first = len(it_rows)
        rec = scheme.advance_window()
        mine = it_rows[first:]
        last = mine[-1]
        r = np.array([m["force_ratio"] for m in mine])
        ok = np.isfinite(r) & (r > 0)
        contraction = (
            float(np.exp(np.mean(np.diff(np.log(r[ok])))))
            if ok.sum() >= 2 and ok.all()
            else math.nan
        )
        win_rows.append(
            {
                "run": tag,
                "window": rec.index,
                "t_end": rec.time,
                "iterations": rec.iterations,
                "converged": int(rec.converged),
                "force_ratio": rec.force_error,
                "force_ratio_first": float(r[0]) if r.size else math.nan,
                "force_contraction": contraction,
                "residual_rel": rec.residual,
                "omega_last": last["omega"],
                "wet_nodes": last["wet_nodes"],
                "wet_runs": last["wet_runs"],
                "accepted_wet_nodes": last["iterate_wet_nodes"],
                "accepted_wet_runs": last["iterate_wet_runs"],
                "set_nodes_dry_at_acceptance": int(
                    last["wet_nodes"] - min(last["wet_nodes"], last["iterate_wet_nodes"])
                ),
                "push_n_per_m": last["push_n_per_m"],
                "suction_n_per_m": last["suction_n_per_m"],
                "mid_mm": last["mid_mm"],
            }
        )
        if rec.index % 10 == 0:
            print(f"{tag}: window {rec.index} to {rec.time:.3f} s: {rec.iterations} it., "
                  f"converged {rec.converged}, force ratio {rec.force_error:.3g}, wet "
                  f"{last['wet_nodes']} nodes in {last['wet_runs']} runs, "
                  f"{time.perf_counter() - tic:.0f} s", flush=True)  # fmt: skip
    return it_rows, win_rows


def probe_map(scheme, fluid, st, mesh, rho, out, wet_pressure=0.0):
    """From the current window start: F(x + eps w) for shapes w and eps (module docstring)."""
    T = scheme.window
    t0, t1 = scheme.t, scheme.t + T
    d_f0 = scheme.mapping.displacement_to_fluid(scheme.d)
    v_f0 = scheme.mapping.velocity_to_fluid(scheme.v, scheme.d)
    x0, s0 = scheme.d + T * scheme.v, scheme.v.copy()  # the window's first iterate
    fluid.checkpoint()

    def forces(x, s):
        fluid.restore()
        F, _ = scheme._fluid_window(
            t0,
            t1,
            d_f0,
            v_f0,
            scheme.mapping.displacement_to_fluid(x),
            scheme.mapping.velocity_to_fluid(s, x),
        )
        return scheme.mapping.forces_to_structure(F, x)

    F0 = forces(x0, s0)
    F0b = forces(x0, s0)
    det = float(np.abs(F0b - F0).max())
    pts = np.asarray(mesh.points)
    trib = np.zeros(pts.shape[0])
    seg = np.linalg.norm(np.diff(pts, axis=0), axis=1)
    trib[:-1] += 0.5 * seg
    trib[1:] += 0.5 * seg
    pressure = np.einsum("ij,ij->i", F0, np.asarray(mesh.normals)) / trib
    print("nodal pressure of the first iterate (Pa), node by node:")
    print(" ".join(f"{p:.2g}" for p in pressure))
    for level in (1e-3, 1e-2, 1e-1, 1.0, 10.0):
        print(f"  nodes with |p| > {level:g} Pa: {int(np.count_nonzero(np.abs(pressure) > level))}")
    # the wet set as the structure decides it (one element around the loaded nodes)
    cells = [np.c_[np.arange(pts.shape[0] - 1), np.arange(1, pts.shape[0])]]
    wet = wet_nodes(
        [F0], cells, pts.shape[0], threshold=wet_pressure * trib if wet_pressure else None
    )
    runs = node_runs(pts, wet)
    if not runs:
        print("  no wet run at this window's start: nothing to probe")
        fluid.restore()
        return
    run = max(runs, key=len)
    s_ = patch_coordinates(pts[run])
    Ma = patch_added_mass(s_, rho)
    n = np.asarray(mesh.normals)[run]
    lw = s_[-1]
    shapes = {
        "heave": np.ones(run.size),
        "sin1": np.sin(np.pi * s_ / lw),
        "sin4": np.sin(4 * np.pi * s_ / lw),
    }
    beta, gamma = 0.25, 0.5
    print(f"t = {t0:.4f} s: wet run of {run.size} nodes from {run.min()} ({lw * 1e3:.1f} mm), "
          f"|F(x) - F(x)| repeat = {det:.3g} N/m")  # fmt: skip
    for name, w in shapes.items():
        ref = float(w @ Ma @ w / (w @ w))
        for eps in (1e-9, 1e-8, 1e-7, 1e-6):
            x = x0.copy()
            x[run] += eps * w[:, None] * n
            s = s0.copy()
            s[run] += (gamma / (beta * T)) * eps * w[:, None] * n
            F = forces(x, s)
            dFn = np.einsum("ij,ij->i", (F - F0)[run], n)
            da = gamma * eps / (beta * T * T)
            m = -float(w @ dFn) / (float(w @ w) * da)
            resid = dFn + m * da * w  # the part of dF not along w
            out.append(
                {
                    "t_start": t0,
                    "shape": name,
                    "eps_m": eps,
                    "m_w_kg_per_m": m,
                    "potential_kg_per_m": ref,
                    "ratio": m / ref,
                    "off_shape_norm_rel": float(np.linalg.norm(resid))
                    / max(float(np.linalg.norm(dFn)), 1e-300),
                    "wet_run_nodes": int(run.size),
                    "wet_run_first_node": int(run.min()),
                    "repeat_diff": det,
                }
            )
            print(f"  {name:6s} eps {eps:7.0e} m: m_w {m:10.4g} kg/m, potential {ref:8.4g} "
                  f"(ratio {m / ref:8.3g}), off-shape {out[-1]['off_shape_norm_rel']:.2f}")  # fmt: skip
    fluid.restore()


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--restart", required=True, type=Path)
    ap.add_argument("--l0", default="0.0057")
    ap.add_argument("--mf", type=float, default=0.5)
    ap.add_argument("--mf-model", default="potential_flow")
    ap.add_argument("--force-tolerance", default="0.05")
    ap.add_argument("--wet-pressure", type=float, default=0.0, help="fictitious_wet_pressure, Pa")
    ap.add_argument("--to", type=float, default=1.64, help="step windows to this time, s")
    ap.add_argument("--windows", type=int, default=2, help="windows recorded from there")
    ap.add_argument(
        "--record-to",
        type=float,
        default=None,
        help="task H3: instead of the probe, record every iteration and window from the "
        "checkpoint (after --to) to this time into bottom_slamming_light_crest_*.csv",
    )
    ap.add_argument("--tag", default=None, help="the run's label in the CSVs (--record-to)")
    ap.add_argument(
        "--set",
        action="append",
        default=[],
        help="extra scenario override KEY=VALUE (repeatable; the in-process branch may change "
        "any key, e.g. fluid.surface.freeze_in_coupling_window=true)",
    )
    ap.add_argument(
        "--patch",
        default=None,
        choices=("hull",),
        help="in-process probe of a structure_fem idea (a proposal, not the code): hull = "
        "the potential-flow M_f over the hull of a split wet patch (merged_runs)",
    )
    args = ap.parse_args(argv)
    apply_patch(args.patch)
    scheme, fluid, st, mesh, sc = build(args)
    if args.record_to is not None:
        return crest(args, scheme, st, mesh)
    print(f"restarted at t = {scheme.t:.4f} s")
    tic = time.perf_counter()
    stepped = []
    while scheme.t < args.to - 1e-9:
        stepped.append(scheme.advance_window().iterations)
    print("iterations of the windows stepped:", " ".join(str(k) for k in stepped[-60:]))
    print(f"stepped to {scheme.t:.4f} s in {time.perf_counter() - tic:.0f} s")
    rows: list[dict] = []
    probe_rows: list[dict] = []
    probe_map(scheme, fluid, st, mesh, sc.fluid.density, probe_rows, args.wet_pressure)
    widx = [0]
    instrument(scheme, st, rows, widx)
    for _ in range(args.windows):
        widx[0] = scheme.index
        rec = scheme.advance_window()
        print(f"window {rec.index} to {rec.time:.4f} s: {rec.iterations} iterations, "
              f"converged {rec.converged}, force error {rec.force_error:.3g}")  # fmt: skip
        for r in rows:
            if r["window"] == rec.index:
                print("   it {iteration:2d}: residual {residual_rms_m:.3g} m, force error "
                      "{force_error_rms:.3g} / load {load_scale_rms:.3g}, load change "
                      "{load_change_norm:.3g} of {load_norm:.3g}".format(**r))  # fmt: skip
    tag = f"{args.mf_model}_mf{args.mf:g}"
    if args.wet_pressure:
        tag += f"_wp{args.wet_pressure:g}"
    for r in rows + probe_rows:
        r["run"] = tag  # the CSVs' first column
    for new, path, key in ((rows, ITER_CSV, "window"), (probe_rows, MAP_CSV, "t_start")):
        if not new:
            continue
        # rows of other runs (or other windows / times of this run) stay
        done = {(tag, str(r[key])) for r in new}
        old = [
            r for r in (read_csv(path) if path.is_file() else []) if (r["run"], r[key]) not in done
        ]
        write_csv(
            old + new, path, columns=["run", *(k for k in new[0] if k != "run")], comment=COMMENT
        )
    print(f"wrote {ITER_CSV.name}, {MAP_CSV.name}")
    return 0


def merged_runs(points: np.ndarray, carrying: np.ndarray) -> list[np.ndarray]:
    """Probe ``--patch hull`` (a proposal for structure_fem, not the code's rule): the wet runs
    of a member merged into one run from its first to its last carrying node, so that the
    potential-flow M_f of a patch split by a dry gap is one operator over the hull (with the
    cross terms between the parts and M_f on the gap's nodes) instead of one per part."""
    runs = node_runs(points, carrying)
    if len(runs) < 2:
        return runs
    p = np.asarray(points, dtype=float)
    order = np.argsort((p - p[0]) @ (p[np.argmax(np.linalg.norm(p - p[0], axis=1))] - p[0]))
    rank = np.empty_like(order)
    rank[order] = np.arange(order.size)
    lo = min(int(rank[r].min()) for r in runs)
    hi = max(int(rank[r].max()) for r in runs)
    return [order[lo : hi + 1]]


def apply_patch(name: str | None) -> None:
    """In-process probes of ideas outside validation/ (reported as proposals, task H3)."""
    if name is None:
        return
    if name == "hull":
        import mpsfem.structure_fem.fictitious_mass as fm

        fm.node_runs = merged_runs
        return
    raise ValueError(f"--patch {name!r}: allowed: hull")


def crest(args, scheme, st, mesh) -> int:
    """The ``--record-to`` mode (task H3): step to ``--to`` unrecorded, record to
    ``--record-to``, merge the rows into the crest CSVs (rows of other runs stay)."""
    print(f"restarted at t = {scheme.t:.4f} s")
    while scheme.t < args.to - 1e-9:
        scheme.advance_window()
    tag = args.tag or f"{args.mf_model}_mf{args.mf:g}_wp{args.wet_pressure:g}"
    it_rows, win_rows = record_stretch(scheme, st, mesh, args.record_to, tag)
    for new, path in ((it_rows, CREST_ITER_CSV), (win_rows, CREST_CSV)):
        old = [r for r in (read_csv(path) if path.is_file() else []) if r["run"] != tag]
        write_csv(old + new, path, columns=list(new[0]), comment=COMMENT + "; task H3 (crest)")
    w = np.array([r["iterations"] for r in win_rows])
    c = np.array([r["converged"] for r in win_rows])
    t = np.array([r["t_end"] for r in win_rows])
    for a, b in ((1.85, 1.95), (1.95, 2.0), (2.0, 2.05), (2.05, 2.1)):
        sel = (t > a + 1e-9) & (t <= b + 1e-9)
        if sel.any():
            print(f"{a:.2f}-{b:.2f} s: {w[sel].mean():.1f} it./window, "
                  f"{int((c[sel] == 0).sum())} of {int(sel.sum())} unconverged")  # fmt: skip
    print(f"wrote {CREST_ITER_CSV.name}, {CREST_CSV.name}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
