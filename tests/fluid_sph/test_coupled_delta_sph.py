"""δ-SPH as the coupled fluid: the hydrostatic water column on a clamped elastic plate
(scenarios/hydrostatic_plate_2d.toml, references.md section 5) through the same coupler as MPS.

Coarse (l0 = 0.05 m, 800 fluid particles, 20 columns on the plate), RK4, implicit IQN-ILS.
Started at rest, the plate oscillates about its static deflection; the time mean over
t in [0.02, 0.06] s (about 6 periods of the wet first mode, ~145 Hz) is compared with beam
theory, w_mid = (rho_w g H + rho_s g h) L^4 / (384 D) = 6.86e-5 m.
"""

from __future__ import annotations

from pathlib import Path

import h5py
import numpy as np
import pytest

from mpsfem.coupler.coupling_scheme import create_scheme
from mpsfem.fluid_methods import create_fluid_participant
from mpsfem.fluid_sph import delta_sph
from mpsfem.fluid_sph.participant import SPHParticipant
from mpsfem.scenario.loader import load_scenario
from mpsfem.simulation import run_coupled
from mpsfem.structure_fem.participant import StructureParticipant

ROOT = Path(__file__).resolve().parents[2]
SCENE = ROOT / "scenarios" / "hydrostatic_plate_2d.toml"
SPH = ['fluid.method="delta-sph"', "fluid.spacing=0.05", "run.threads=1"]
RHO, G, H, L = 1000.0, 9.81, 2.0, 1.0
D = 67.5e9 * 0.05**3 / (12 * (1 - 0.34**2))  # plate-strip rigidity, N m
T_END, SETTLE = 0.06, 0.02  # s: run, start of the time means
W_STATIC = (RHO * G * H + 2700.0 * G * 0.05) * L**4 / (384 * D)  # clamped-clamped, m


def _coupled(extra=()):
    loaded = load_scenario(SCENE, [*SPH, *extra])
    sc = loaded.scenario
    st = StructureParticipant(sc.structure, base_dir=SCENE.parent)
    fl = create_fluid_participant(
        sc.fluid, st.interface(), base_dir=SCENE.parent, member_names=["plate"]
    )
    scheme = create_scheme(fl, st, sc.coupling, log=lambda m: None)
    scheme.initialize()
    return fl, st, scheme


@pytest.fixture(scope="module")
def settled():
    """T_END s of the coarse coupled run: mid deflection and plate force after each window."""
    fl, st, scheme = _coupled()
    t, w, f = [], [], []
    while scheme.t < T_END - 1e-9:
        scheme.advance_window()
        t.append(scheme.t)
        w.append(st.read("displacement")[10, 1])
        f.append(fl.member_force("plate"))
    return fl, np.array(t), np.array(w), np.array(f)


def test_participant_is_chosen_by_method():
    fl, _, _ = _coupled()
    assert isinstance(fl, SPHParticipant)
    # the force read before the first step is the hydrostatic load of the initial state
    f0 = fl.read("forces").sum(axis=0)
    assert abs(f0[0]) < 1e-6 * RHO * G * H * L
    assert f0[1] == pytest.approx(-RHO * G * H * L, rel=0.05)


def test_mean_deflection_matches_beam_theory(settled):
    """Measured: 6.91e-5 m, +0.8 % over beam theory (over t >= 0.03 s: +1.4 %, >= 0.04 s:
    +0.7 %; the validation run's mean over [0.05, 0.2] s: -0.35 %). Tolerance 3 %: the mean of
    the start-up oscillation (std 4e-6 m, 6 % of the mean) over 6 periods moves by ~1.5 % with
    the averaging window, and the load is 1.5-2.5 % short of rho g H L (next test)."""
    _, t, w, _ = settled
    mean = w[t >= SETTLE].mean()
    assert mean == pytest.approx(-W_STATIC, rel=0.03)


def test_plate_force_is_the_water_weight(settled):
    """Mean vertical force on the plate vs rho g H L = 19 620 N/m. Measured 1.5 % short at
    l0 = 0.05 (2.5 % over [0.05, 0.2] s): the water in the two bottom corners leans on the side
    walls' dummy particles below the plate's level, within the support 2h = 0.13 m. Tolerance
    4 %; the horizontal force vanishes by the left-right symmetry (measured 2e-16 of the
    weight; bound 0.5 %)."""
    _, t, _, f = settled
    mean = f[t >= SETTLE].mean(axis=0)
    assert mean[1] == pytest.approx(-RHO * G * H * L, rel=0.04)
    assert abs(mean[0]) < 0.005 * RHO * G * H * L


def test_force_is_what_the_fluid_loses():
    """Momentum balance of one right-hand side: the δ-SPHC pressure pairs (p_i M_i + p_j M_j)
    and the viscous pairs between fluid particles are antisymmetric, so the fluid's total
    rate of momentum is its weight less the reactions on every wall particle (plate and
    side walls, ``wall_reaction`` over all wall rows), to rounding; and the plate's share is
    the participant's force."""
    fl, _, _ = _coupled()
    s = fl.solver
    s.rhs()
    nf = s.n_fluid
    nb = s._last_neighbours
    slot = np.full(s.n, -1, dtype=np.int64)
    slot[nf:] = np.arange(s.n - nf)
    every = np.zeros((s.n - nf, 2))
    delta_sph.wall_reaction(
        s.pos, s.rho, s.vol, s.p, nb.indptr, nb.indices, nf, s.inv_h, s.grad_coef,
        s.corrected, s.M, slot, every,
    )  # fmt: skip
    rate = s.mass * s.acc[:nf].sum(axis=0)  # N/m
    weight = nf * s.mass * s.gravity
    scale = RHO * G * H * L
    assert np.abs(rate - (weight - every.sum(axis=0))).max() < 1e-9 * scale
    assert np.array_equal(every[s.ext_rows - nf], s.reaction)
    assert np.allclose(fl.read("forces").sum(axis=0), s.reaction.sum(axis=0), rtol=1e-12)


@pytest.mark.parametrize("integrator", ["rk4", "symplectic"])
def test_step_force_weights_the_stages(integrator):
    """The force read after a step is the integrator's weighted mean of the right-hand sides'
    reactions, the one that makes dt F the fluid's momentum loss over the step: RK4 (F1 + 2 F2
    + 2 F3 + F4) / 6, leapfrog (F_start + F_end) / 2 (its two half kicks)."""
    fl, st, scheme = _coupled([f'fluid.sph={{integrator="{integrator}"}}'])
    s = fl.solver
    scheme.advance_window()  # the plate moving
    seen = [s.reaction.copy()]  # the reaction of the state the step starts from
    rhs = s.rhs

    def recording():
        rhs()
        seen.append(s.reaction.copy())

    s.rhs = recording
    fl.write("displacement", fl._d + 1e-6)  # the plate moves during the step
    fl.advance(s.dt_next)
    if integrator == "rk4":
        expect = (seen[1] + 2 * seen[2] + 2 * seen[3] + seen[4]) / 6.0
        assert len(seen) == 5
    else:
        expect = 0.5 * (seen[0] + seen[1])
        assert len(seen) == 2
    assert np.allclose(s.reaction_step, expect, rtol=1e-13, atol=1e-12 * RHO * G * H)
    assert not np.array_equal(seen[0], seen[-1])


def test_restart_is_bit_identical(tmp_path):
    """A coupled δ-SPH run restarted from its checkpoint at window 3 repeats the uninterrupted
    run's results bit for bit (implicit windows restore the fluid each iteration, too)."""

    def run(name, end, extra=(), restart=None):
        loaded = load_scenario(
            SCENE, [*SPH, "output.snapshot_interval=0.0004", "output.probe_interval=2e-4", *extra]
        )
        out = tmp_path / f"{name}.h5"
        run_coupled(loaded, out, end, restart, progress=False, log=lambda m: None)
        return out

    full = run("full", 6 * 2e-4)
    part = run("part", 3 * 2e-4, ["output.checkpoint_interval=6e-4"])
    ckpt = part.with_name("part.ckpt.h5")
    run("part", 6 * 2e-4, ["output.checkpoint_interval=6e-4"], restart=ckpt)

    def data(path):
        out = {}
        with h5py.File(path, "r") as h5:
            h5.visititems(
                lambda n, o: out.__setitem__(n, o[()]) if isinstance(o, h5py.Dataset) else None
            )
        return out

    a, b = data(full), data(part)
    keys = [k for k in a if not k.startswith(("coupling/wall_", "restarts"))]
    differ = [k for k in keys if k not in b or a[k].tobytes() != b[k].tobytes()]
    assert differ == []
    with h5py.File(full, "r") as h5:
        assert h5.attrs["status"] == "finished"
        f = h5["probes/plate_force/value"][()]
    # the plate starts at rest and falls: the load dips during the first milliseconds
    assert np.isfinite(f).all() and (f[:, 1] < 0).all()


def test_3d_plate_is_refused():
    from types import SimpleNamespace

    loaded = load_scenario(SCENE, SPH)
    mesh = SimpleNamespace(
        points=np.zeros((4, 3)),
        normals=np.tile([0.0, 0.0, 1.0], (4, 1)),
        cells={"quad": np.array([[0, 1, 2, 3]])},
        thickness=0.01,
    )
    with pytest.raises(ValueError, match="2D beam members only"):
        SPHParticipant(loaded.scenario.fluid, mesh)


# ------------------------------------------------------------ a free member end under δ-SPH
def _shelf(use_filter: bool = True, steps: int = 20, load: str = "normal"):
    """Still water 0.3 m deep (l0 = 0.01 m) in a tank 0.41 m wide around a horizontal member one
    spacing thick at y = 0.155 m, from the left wall to its free end at x = 0.3 m (tests/
    fluid_mps/test_thin_member.py's shelf scene), ``steps`` δ-SPH steps of the participant (the
    member held still): water above, below and beyond the free end."""
    from mpsfem.coupler.participant import InterfaceMesh
    from mpsfem.scenario.fluid import FluidSection

    n_el, l0 = 10, 0.01
    pts = np.c_[np.linspace(0.0, 0.3, n_el + 1), np.full(n_el + 1, 0.155)]
    mesh = InterfaceMesh(
        pts,
        np.tile([0.0, 1.0], (n_el + 1, 1)),
        {"line": np.c_[np.arange(n_el), np.arange(1, n_el + 1)]},
        l0,
    )
    fluid = FluidSection.model_validate(
        {
            "method": "delta-sph",
            "spacing": l0,
            "blocks": [{"lower": [0, 0], "upper": [0.41, 0.3]}],
            "walls": [{"shape": "tank", "name": "tank", "lower": [0, 0], "upper": [0.41, 0.5]}],
            "sph": {"structure_load": load},
        }
    )
    fl = SPHParticipant(fluid, mesh, member_names=["shelf"])
    frame = fl.surface.frames[0]
    assert (frame.free_start, frame.free_end) == (False, True)  # root at the wall, free tip
    if not use_filter:
        fl.solver.neighbour_filter = None
    for _ in range(steps):
        fl.advance(fl.max_dt())
    return fl


#: fluid.sph.structure_load = "normal_pairs" projects every pair of the fluid with a member's
#: particles on the member's normals: the (p_i + p_j) pairs then lose the kernel's zeroth-order
#: consistency where the member's particles are not symmetric about a fluid particle along the
#: face (its root at a wall, its free end: 30 m/s^2 along the shelf at rest, measured) and where
#: the pressure varies along a face (a vertical member in still water)
PAIRS_COST = pytest.mark.xfail(
    strict=True,
    reason="structure_load = 'normal_pairs' drops the tangential part of the member's pairs, "
    "which the fluid's pressure gradient needs near the member's ends and along faces the "
    "pressure varies on: shelf rms 66 / 71 / 100 Pa (above / below / tip, tolerance 49), "
    "partition F_x 153.6 N/m (+4.4 %, tolerance 3 %); docs/fluid_sph.md",
)


@pytest.mark.parametrize("load", ["normal", pytest.param("normal_pairs", marks=PAIRS_COST)])
def test_free_end_keeps_still_water_hydrostatic(load):
    """The shelf scene under δ-SPH after 20 steps (6 ms): the fluid within 4 spacings of the
    member, above it, below it and around its free end, keeps rho g (0.3 - y) within
    rho g l0 / 2 rms (a face is resolved to +-l0/2; MPS's tolerance, tests/fluid_mps/
    test_thin_member.py; measured 3.1, 3.8 and 7.1 Pa), and the member carries the pressure
    difference across its thickness, Archimedes' rho g T x 0.3 m = 29.43 N/m upward, within 5 %
    (measured 29.17 N/m, -0.9 %; the coupled plate's load is 1.2-2.5 % short from the fluid
    in the corners, docs/fluid_sph.md). Without the thin-member filter the water above and
    below mix through the member: the scene fails the pressure tolerance."""
    rho, g, l0 = 1000.0, 9.81, 0.01
    tol = 0.5 * rho * g * l0

    def errors(fl):
        s = fl.solver
        f = np.arange(s.n) < s.n_fluid
        x, y = s.pos[:, 0], s.pos[:, 1]
        near = f & (np.abs(y - 0.155) < 4 * l0) & (y < 0.3 - 3 * l0)
        parts = {
            "above": near & (y > 0.16) & (x < 0.3 - 3 * l0),
            "below": near & (y < 0.15) & (x < 0.3 - 3 * l0),
            "tip": near & (np.abs(x - 0.3) < 3 * l0),
        }
        out = {}
        for k, m in parts.items():
            assert m.sum() > 10, k
            out[k] = float(np.sqrt(np.mean((s.p[m] - rho * g * (0.3 - y[m])) ** 2)))
        return out

    fl = _shelf(load=load)
    e = errors(fl)
    fy = fl.member_force("shelf")[1]
    print(f"δ-SPH shelf: rms p error {e} Pa (tolerance {tol:.1f}); net F_y {fy:.2f} N/m")
    assert max(e.values()) < tol
    assert fy == pytest.approx(rho * g * l0 * 0.3, rel=0.05)
    unfiltered = errors(_shelf(use_filter=False, load=load))
    print(f"without the filter: rms p error {unfiltered} Pa")
    assert unfiltered["below"] > tol


@pytest.mark.parametrize("load", ["normal", pytest.param("normal_pairs", marks=PAIRS_COST)])
def test_partition_carries_the_hydrostatic_resultant(load):
    """A vertical member one spacing thick (l0 = 0.01 m) from the floor to a free end at 0.3 m,
    water 0.2 m deep on its left and 0.1 m on its right (MPS's partition scene, tests/fluid_mps/
    test_thin_member.py), 20 δ-SPH steps: the horizontal load is rho g (H1^2 - H2^2) / 2 =
    147.15 N/m within 3 % (measured 143.85, -2.2 %; δ-SPH's water leans on the walls' dummies
    near the corners, which leaves the coupled plate's load 1.2-2.5 % short, docs/fluid_sph.md),
    and still water pushes it neither up nor down: |F_y| < 1 % of F_x (measured 0 with the
    default normal load, -0.52 N/m with structure_load = "exchange"; the elastic obstacle's
    upward load during its impact came with the flow, docs/validation_delta_sph_coupled.md,
    "Axial load")."""
    from mpsfem.coupler.participant import InterfaceMesh
    from mpsfem.scenario.fluid import FluidSection

    n_el, l0 = 10, 0.01
    pts = np.c_[np.full(n_el + 1, 0.205), np.linspace(0.0, 0.3, n_el + 1)]
    mesh = InterfaceMesh(
        pts,
        np.tile([-1.0, 0.0], (n_el + 1, 1)),
        {"line": np.c_[np.arange(n_el), np.arange(1, n_el + 1)]},
        l0,
    )
    blocks = [([0, 0], [0.2, 0.2]), ([0.2, 0], [0.41, 0.1])]
    fluid = FluidSection.model_validate(
        {
            "method": "delta-sph",
            "spacing": l0,
            "blocks": [{"lower": lo, "upper": hi} for lo, hi in blocks],
            "walls": [{"shape": "tank", "name": "tank", "lower": [0, 0], "upper": [0.41, 0.4]}],
            "sph": {"structure_load": load},
        }
    )
    fl = SPHParticipant(fluid, mesh, member_names=["m"])
    frame = fl.surface.frames[0]
    assert (frame.free_start, frame.free_end) == (False, True)  # clamped at the floor
    for _ in range(20):
        fl.advance(fl.max_dt())
    f = fl.member_force("m")
    exact = 0.5 * RHO * G * (0.2**2 - 0.1**2)
    print(f"δ-SPH partition: F = {f} N/m, exact F_x {exact:.2f}")
    assert f[0] == pytest.approx(exact, rel=0.03)
    assert abs(f[1]) < 0.01 * f[0]


# ------------------------------------------------------- the elastic obstacle study's CSV
@pytest.mark.slow
def test_obstacle_study_results():
    """validation/results/delta_sph_obstacle.csv (validation/delta_sph_obstacle.py: the dam break
    on the elastic obstacle, δ-SPH and MPS at L/20, L/40 and L/80 to 0.3 s, at L/20 to 0.6 s,
    δ-SPH with structure_load = "normal_pairs" at L/20 and L/40). Every run finished and every
    coupling window converged (measured: all of them; δ-SPH at most 3 iterations); the 0.6 s
    runs repeat the 0.3 s runs' impact figures exactly. δ-SPH's momentum budget closes: its
    internal pairs cancel (the residual with them equals the one without them to round-off;
    docs/fluid_sph.md; MPS's do not cancel), and with the tank's force reported as its pair
    exchange (boundary_force = "momentum_exchange") residual_external is round-off (1e-9 of the
    boundary impulse; it was -2 to -12 % with the pressure integral). With "normal_pairs" the
    member's load impulse (force probe) over the impact is the fluid's exchange with it (1e-6:
    round-off of the 1 ms interval means); with the default "normal" it is not (measured
    -4.4 % / +1.5 % in x at L/20 / L/40)."""
    import sys

    sys.path.insert(0, str(ROOT / "validation"))
    from results_csv import read_csv

    every = {r["case"]: r for r in read_csv(ROOT / "validation/results/delta_sph_obstacle.csv")}
    base = (
        "dsph20", "dsph40", "mps20", "mps40", "dsph80", "mps80", "dsph20_long", "mps20_long",
        "dsph20_pairs", "dsph40_pairs",
    )  # fmt: skip
    rows = {k: every[k] for k in base}  # the later diagnostics' cases: their own tests
    for key, r in rows.items():
        t_end = 0.6 if key.endswith("_long") else 0.3
        assert r["status"] == "finished" and float(r["t_end_s"]) == pytest.approx(t_end)
        assert int(r["not_converged"]) == 0 and int(r["windows"]) == round(t_end / 2.5e-4)
    for key in ("dsph20", "mps20"):  # the 0.6 s run is the 0.3 s run continued, bit for bit
        for col in ("tip_peak_mm", "tip_peak_time_s", "member_impulse_x", "ringing_mean"):
            assert rows[key][col] == rows[f"{key}_long"][col]
    sph = [r for k, r in rows.items() if k.startswith("dsph")]
    for r in sph:
        assert int(r["iterations_max"]) < 30
        for ax in "xy":
            assert float(r[f"residual_rel_{ax}"]) == pytest.approx(
                float(r[f"residual_external_rel_{ax}"]), abs=1e-9
            )
            assert abs(float(r[f"residual_external_rel_{ax}"])) < 1e-9
    for key in ("dsph20_pairs", "dsph40_pairs"):
        for ax in "xy":
            assert abs(float(rows[key][f"load_gap_rel_{ax}"])) < 1e-6
    assert abs(float(rows["dsph20"]["load_gap_rel_x"])) > 0.01


@pytest.mark.slow
def test_obstacle_ringing_is_the_fluids():
    """The ringing diagnosis of docs/fluid.md ("What the ringing is"): the obstacle made 2e5
    times stiffer (E = 2e11 Pa, cases *_stiff; its tip moves microns) rings under MPS at least
    0.8 times as much as the elastic plate at L/20 and L/40 (measured 0.85 and 1.09: the
    realisations of one case spread by about a quarter, cases mps20_stiff_*), and δ-SPH on
    the same stiff plate rings less than MPS (measured 0.106 against 0.190 at L/40). Per
    coupling window (delta_sph_obstacle_noise.csv) MPS's load residual is white (lag-1
    autocorrelation within +-0.3 of 0; measured -0.18 to 0.07) and coherent over the wetted face
    (variance of the summed jump at least twice the sum of the nodes'; measured 3.2-9.4),
    δ-SPH's red (lag-1 above 0.5; measured 0.73)."""
    import sys

    sys.path.insert(0, str(ROOT / "validation"))
    from results_csv import read_csv

    rows = {r["case"]: r for r in read_csv(ROOT / "validation/results/delta_sph_obstacle.csv")}
    stopped = ("mps20_stiff_nocoll", "mps20_stiff_nocoll_ds", "mps20_stiff_cd0.6")
    stiff = [k for k in rows if "_stiff" in k and k not in stopped]
    assert len(stiff) == 23 and all(rows[k]["status"] == "finished" for k in stiff)
    for k in stiff:
        assert float(rows[k]["tip_peak_mm"]) < 0.01  # a member that does not move
    # without the collision model the MPS run cannot go on (its time step collapses), and with
    # the collision distance 0.6 l0 a particle is thrown out of the tank
    for k in ("mps20_stiff_nocoll", "mps20_stiff_nocoll_ds"):
        assert rows[k]["status"].startswith("failed: FluidRunError: time step")
    assert rows["mps20_stiff_cd0.6"]["status"].startswith("failed: FluidRunError: fluid particle")
    for n in (20, 40):
        elastic = float(rows[f"mps{n}"]["ringing_mean"])
        assert float(rows[f"mps{n}_stiff"]["ringing_mean"]) > 0.8 * elastic
    assert float(rows["dsph40_stiff"]["ringing_mean"]) < float(rows["mps40_stiff"]["ringing_mean"])
    noise = {
        r["case"]: r
        for r in read_csv(ROOT / "validation/results/delta_sph_obstacle_noise.csv")
        if r.get("windows") not in (None, "")
    }
    for k in ("mps20_stiff", "mps20", "mps40_stiff"):
        assert abs(float(noise[k]["residual_lag1_autocorrelation"])) < 0.3
        assert float(noise[k]["variance_ratio"]) > 2.0
    assert float(noise["dsph40_stiff"]["residual_lag1_autocorrelation"]) > 0.5


@pytest.mark.slow
def test_mps_load_noise_is_the_divergence_share():
    """docs/fluid.md, "Where the per-step noise comes from" (validation/mps_pressure_split.py,
    delta_sph_obstacle_pressure_split.csv: the stiff obstacle at L/20 at the Courant numbers
    0.05, 0.1 and 0.2). The pressure equation's three parts sum to its right-hand side exactly
    (the split is the solve's own); the member's force jumps more from step to step the shorter
    the step (measured 381, 325, 216 N/m); the velocity divergence's share carries the total's
    jumps in every band (correlation above 0.85; measured 0.886-0.974); the correction leaves
    most of the interior divergence (above 0.8; measured 0.84-0.96), and the first-order
    consistent divergence of the same velocities is larger than MPS's (noise, not the
    operator's error on a smooth flow); near the plate the clamped mean stays within 5 % while
    the solved mean moves by more than 5 kPa (measured 2607-2665 Pa; -4510 to +1721 Pa)."""
    import sys

    sys.path.insert(0, str(ROOT / "validation"))
    from results_csv import read_csv

    path = ROOT / "validation/results/delta_sph_obstacle_pressure_split.csv"
    rows = {r["case"]: {k: float(v) for k, v in r.items() if k != "case"} for r in read_csv(path)}
    key = "mps20_stiff+fluid.time_step.courant="
    order = [rows[key + "0.05"], rows["mps20_stiff"], rows[key + "0.2"]]
    assert [r["dt_mean_s"] for r in order] == sorted(r["dt_mean_s"] for r in order)
    jumps = [r["force_step_jump_rms"] for r in order]
    assert jumps == sorted(jumps, reverse=True)
    for r in order:
        assert r["split_error_max"] < 1e-10
        for band in ("near", "mid", "far"):
            assert r[f"{band}_divergence_jump_corr"] > 0.85
        assert r["interior_div_left_share"] > 0.8
        assert r["interior_div_ustar_corrected"] > r["interior_div_ustar"]
    clamped = [r["near_clamped_mean"] for r in order]
    solved = [r["near_solved_mean"] for r in order]
    assert max(clamped) < 1.05 * min(clamped)
    assert max(solved) - min(solved) > 5000.0


@pytest.mark.slow
def test_a_kernel_filtered_source_kicks_as_hard():
    """docs/fluid.md, "The noise is not the particle-scale divergence": with the source's
    divergence averaged over the kernel (fluid.pressure.source_filter = "kernel_average") the
    stiff obstacle at L/20 rings within the default's spread of realisations (the 1 ms jump
    118-150 N/m; measured 138 N/m), its divergence share jumps within 20 % of the default's in
    every band (measured +4 to +7 %), while the unfiltered divergence it no longer asks the
    projection for grows (interior RMS 2.29 against 1.59 1/s)."""
    import sys

    sys.path.insert(0, str(ROOT / "validation"))
    from results_csv import read_csv

    rows = {r["case"]: r for r in read_csv(ROOT / "validation/results/delta_sph_obstacle.csv")}
    r = rows["mps20_stiff_sfilt"]
    assert r["status"] == "finished"
    jump = float(r["ringing_mean"]) * float(r["force_peak_mean"])
    assert 118.0 <= jump <= 150.0
    path = ROOT / "validation/results/delta_sph_obstacle_pressure_split.csv"
    split = {q["case"]: {k: float(v) for k, v in q.items() if k != "case"} for q in read_csv(path)}
    base = split["mps20_stiff"]
    filt = split['mps20_stiff+fluid.pressure.source_filter="kernel_average"']
    assert filt["split_error_max"] < 1e-10  # the split sums to the filtered source's solve
    for band in ("near", "mid", "far"):
        ratio = filt[f"{band}_divergence_jump"] / base[f"{band}_divergence_jump"]
        assert 0.8 < ratio < 1.2, band
    assert filt["interior_div_ustar"] > 1.2 * base["interior_div_ustar"]


@pytest.mark.slow
@pytest.mark.xfail(
    strict=True,
    reason="with fluid.sph.structure_load = 'normal' the δ-SPH tip peak is a plateau (L/20: "
    "29-31 mm over 0.204-0.240 s, L/40: 33.3-35.5 mm over 0.208-0.256 s) whose largest sample is "
    "its first bump at L/20 (0.210 s) and its last at L/40 (0.238 s): 28 ms apart",
)
def test_obstacle_peak_time_agrees_between_resolutions():
    """δ-SPH's first tip peak at the same time at L/20 and L/40 within 10 ms (the elastic-gate
    study's tolerance for its spacings, tests/scenarios/test_elastic_gate.py; measured 4 ms
    with structure_load = "exchange", 28 ms with "normal": docs/validation_delta_sph_coupled.md)."""
    import sys

    sys.path.insert(0, str(ROOT / "validation"))
    from results_csv import read_csv

    rows = {r["case"]: r for r in read_csv(ROOT / "validation/results/delta_sph_obstacle.csv")}
    t20, t40 = (float(rows[k]["tip_peak_time_s"]) for k in ("dsph20", "dsph40"))
    assert abs(t20 - t40) < 0.01


# ------------------------------------------------- the load on a member standing on the floor
def _surge_on_member(load: str, theta: float = 0.0, steps: int = 40):
    """A layer of water 0.06 m deep moving at 1 m/s (l0 = 0.01 m) against a member one spacing
    thick standing on the floor at x = 0.205 m, 0.15 m tall (the run-up v^2 / 2g = 0.05 m leaves
    its free end dry), held still and turned clockwise by ``theta`` about its foot;
    ``steps`` δ-SPH steps (0.024 s: the layer strikes it). Returns the member's impulse (N s/m),
    the last forces and current normals of the interface points and the participant."""
    from mpsfem.coupler.participant import InterfaceMesh
    from mpsfem.scenario.fluid import FluidSection

    n_el, l0, x_m = 10, 0.01, 0.205
    pts = np.c_[np.full(n_el + 1, x_m), np.linspace(0.0, 0.15, n_el + 1)]
    mesh = InterfaceMesh(
        pts,
        np.tile([-1.0, 0.0], (n_el + 1, 1)),
        {"line": np.c_[np.arange(n_el), np.arange(1, n_el + 1)]},
        l0,
    )
    fluid = FluidSection.model_validate(
        {
            "method": "delta-sph",
            "spacing": l0,
            "blocks": [{"lower": [0.0, 0.0], "upper": [0.19, 0.06], "velocity": [1.0, 0.0]}],
            "walls": [{"shape": "tank", "name": "tank", "lower": [0, 0], "upper": [0.41, 0.3]}],
            "sph": {"structure_load": load},
        }
    )
    fl = SPHParticipant(fluid, mesh, member_names=["m"])
    rel = fl.interface().points - [x_m, 0.0]
    c, s = np.cos(theta), np.sin(theta)
    turned = np.c_[c * rel[:, 0] + s * rel[:, 1], c * rel[:, 1] - s * rel[:, 0]]
    fl.write("displacement", turned - rel)
    impulse = np.zeros(2)
    for _ in range(steps):
        dt = fl.max_dt()
        fl.advance(dt)
        impulse += dt * fl.member_force("m")
    return impulse, fl._forces(), fl.solver.normal[fl._if_rows], fl


@pytest.mark.parametrize("theta", [0.0, 0.05])
def test_surge_loads_a_standing_member_normal_to_its_faces(theta):
    """An inviscid fluid pushes a free-slip member normal to its faces: a surge striking a member
    standing on the floor (upright, or turned by 0.05 rad) puts no load along it, as MPS's
    -p A n does. The pair exchange with the member's virtual particles has a tangential part
    where the pressure varies along a face (one-sided kernel support; worst in the floor corner):
    measured -0.077 N s/m against 3.17 N s/m normal (2.4 %) upright, which put a net upward load
    on the elastic obstacle (docs/validation_delta_sph_coupled.md, "Axial load"). With
    structure_load = "normal" (default) the load along the member is zero to round-off (bound
    1e-3 of the normal impulse; the free end's corner points stay dry here), and the
    normal load is the exchange's unchanged (to round-off: only the tangential part goes)."""
    t_up = np.array([np.sin(theta), np.cos(theta)])  # along the member, foot to free end
    n_left = np.array([-t_up[1], t_up[0]])  # the struck face's outward normal
    j_new, f, nrm, fl = _surge_on_member("normal", theta)
    j_old, *_ = _surge_on_member("exchange", theta)
    print(f"theta {theta}: exchange {j_old} N s/m, normal {j_new} N s/m")
    assert -(j_old @ n_left) > 1.0  # the surge struck: > 1 N s/m (measured 2.9-3.2)
    assert abs(j_old @ t_up) > 1e-3 * abs(j_old @ n_left)  # the defect is there to remove
    assert abs(j_new @ t_up) < 1e-3 * abs(j_new @ n_left)
    assert j_new @ n_left == pytest.approx(j_old @ n_left, rel=1e-12)
    k = fl._project
    top = fl.interface().points[:, 1] == fl.interface().points[:, 1].max()
    assert top.sum() == 2 and (k == ~top).all()  # the free end's two corners are kept whole
    assert np.abs(f[k, 0] * nrm[k, 1] - f[k, 1] * nrm[k, 0]).max() < 1e-9 * np.abs(f).max()
    assert np.abs(f[~k]).max() == 0.0  # dry free end


@pytest.mark.parametrize("theta", [0.0, 0.1])
def test_free_end_is_pushed_not_pulled(theta):
    """structure_load = "normal" at the free end's corner points (face and cap): the face part
    is the exchange along the current face normal, the cap part along the current cap normal
    (the member's axis) only where it pushes. A synthetic step reaction on the member turned by
    ``theta``: pull along the axis and push on the face on the corner's own particle, a
    tangential force on a face particle; "exchange" hands them over whole."""
    from mpsfem.coupler.participant import InterfaceMesh
    from mpsfem.scenario.fluid import FluidSection

    n_el, l0, x_m = 10, 0.01, 0.205
    pts = np.c_[np.full(n_el + 1, x_m), np.linspace(0.0, 0.15, n_el + 1)]
    mesh = InterfaceMesh(
        pts,
        np.tile([-1.0, 0.0], (n_el + 1, 1)),
        {"line": np.c_[np.arange(n_el), np.arange(1, n_el + 1)]},
        l0,
    )
    out = {}
    for load in ("normal", "exchange"):
        fluid = FluidSection.model_validate(
            {
                "method": "delta-sph",
                "spacing": l0,
                "blocks": [{"lower": [0.0, 0.0], "upper": [0.1, 0.05]}],
                "walls": [{"shape": "tank", "name": "tank", "lower": [0, 0], "upper": [0.41, 0.3]}],
                "sph": {"structure_load": load},
            }
        )
        fl = SPHParticipant(fluid, mesh, member_names=["m"])
        rel = fl.interface().points - [x_m, 0.0]
        c, s = np.cos(theta), np.sin(theta)
        fl._d = np.c_[c * rel[:, 0] + s * rel[:, 1], c * rel[:, 1] - s * rel[:, 0]] - rel
        fl.surface.place(fl.solver, fl._d, fl._v)  # the turned normals
        pts_y = fl.interface().points[:, 1]
        left = fl.interface().normals[:, 0] < -0.5  # the -x face and its corner
        corner = int(np.flatnonzero(left & (pts_y == pts_y.max()))[0])
        face = int(np.flatnonzero(left & (pts_y < 0.05))[0])
        axis = np.array([s, c])  # foot to free end, turned clockwise by theta
        n_face = np.array([-c, s])  # the -x face's outward normal, turned
        fl.solver.reaction_step[...] = 0.0
        slot = fl.solver.ext_slot[fl.surface.interface_index]
        fl.solver.reaction_step[slot[corner]] = 30.0 * axis - 50.0 * n_face  # pulled, pushed
        fl.solver.reaction_step[slot[face]] = 7.0 * axis - 40.0 * n_face  # tangential 7 N/m
        out[load] = (fl._forces(), corner, face, axis, n_face)
        if load == "normal":  # the cap pushed (water on the free end): kept whole
            fl.solver.reaction_step[slot[corner]] = -30.0 * axis - 50.0 * n_face
            np.testing.assert_allclose(
                fl._forces()[corner], -30.0 * axis - 50.0 * n_face, atol=1e-12
            )
    f, corner, face, axis, n_face = out["normal"]
    np.testing.assert_allclose(f[corner], -50.0 * n_face, atol=1e-12)  # the pull on the cap dropped
    np.testing.assert_allclose(f[face], -40.0 * n_face, atol=1e-12)  # the tangential part dropped
    f, *_ = out["exchange"]
    np.testing.assert_allclose(f[corner], 30.0 * axis - 50.0 * n_face, atol=1e-12)
    np.testing.assert_allclose(f[face], 7.0 * axis - 40.0 * n_face, atol=1e-12)


def test_coupled_run_on_candidates_gives_the_exact_lists_bits():
    """A coupled run (thin-member filter, the member's reaction, the budget) takes the Verlet
    candidates, filtered on a copy (``DeltaSPHSolver.neighbour_rows``); the same run on the
    shared search's exact list gives every fluid and structure array equal, bit for bit, over
    40 windows."""
    from mpsfem.fluid_mps.neighbours import NeighbourSearch

    runs = []
    for exact in (False, True):
        fl, st, scheme = _coupled(["fluid.momentum_budget=true"])
        s = fl.solver
        assert s.budget.full and s.neighbour_filter is not None and s.ext_rows.size
        if exact:
            s.exact_neighbours = True
            s.search = NeighbourSearch(s.dim, s.radius, domain=(s.lower, s.upper),
                                       skin=s.spec.neighbours.skin * s.spec.spacing)  # fmt: skip
        for _ in range(40):
            scheme.advance_window()
        runs.append((fl, st))
    (fa, sa), (fb, sb) = runs
    assert fa.solver.search.reuses > fa.solver.search.builds  # the candidates were reused
    for k, v in fa.solver.state().items():
        assert np.array_equal(v, fb.solver.state()[k]), k
    assert np.array_equal(sa.read("displacement"), sb.read("displacement"))
    assert np.array_equal(fa.solver.budget.ledger, fb.solver.budget.ledger)
