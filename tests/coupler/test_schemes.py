"""Coupling schemes on the mock added-mass problem (mpsfem.coupler.mock).

Structure: spring-mass member, fluid: added-mass force -m_a a on particles on both faces, mapped
with the shape-function mapping. Mass ratio mu = added / structure mass.
"""

from __future__ import annotations

import copy
import warnings

import numpy as np
import pytest

from mpsfem.coupler import mock
from mpsfem.coupler.convergence import ResidualCriterion
from mpsfem.coupler.coupling_scheme import ExplicitScheme, ImplicitScheme, create_scheme
from mpsfem.coupler.errors import (
    CouplingDivergedError,
    CouplingNotConvergedError,
    CouplingWarning,
)
from mpsfem.coupler.participant import InterfaceMesh
from mpsfem.scenario.coupling import CouplingSection


def config(**kw) -> CouplingSection:
    data = {"mapping": {"kind": "shape-function"}}
    data.update(kw)
    return CouplingSection.model_validate(data)


def reference(mu: float, windows: int, T: float = 1e-3) -> np.ndarray:
    """The monolithic solution of the same discrete problem (what implicit coupling converges
    to): :func:`mpsfem.coupler.mock.monolithic_reference`."""
    return mock.monolithic_reference(mu, windows, T)


def run(mu, end=0.1, **kw):
    fluid, st = mock.pair(mu)
    sch = create_scheme(fluid, st, config(**kw))
    trace = []
    sch.run(end, on_window=lambda r: trace.append(st.u.copy()))
    return sch, np.array(trace), st


@pytest.mark.parametrize("mu", [10.0, 3.0])
def test_explicit_diverges_for_heavy_fluid_and_says_so(mu):
    with pytest.raises(CouplingDivergedError, match="added-mass instability") as err:
        run(mu, scheme="explicit")
    assert 'scheme = "implicit"' in str(err.value)


@pytest.mark.parametrize("mu", [1.0, 0.1, 0.01])
def test_explicit_stable_for_light_fluid(mu):
    sch, trace, _ = run(mu, scheme="explicit")
    assert isinstance(sch, ExplicitScheme)
    assert (sch.history.column("iterations") == 1).all()
    assert np.abs(trace).max() < 0.2


@pytest.mark.parametrize("mu", [10.0, 3.0, 1.0, 0.1, 0.01])
def test_implicit_iqn_ils_stable_and_matches_monolithic(mu):
    tol = 1e-9
    sch, trace, _ = run(
        mu,
        convergence={"relative_tolerance": tol, "absolute_tolerance": 1e-14, "max_iterations": 60},
    )
    assert isinstance(sch, ImplicitScheme)
    ref = reference(mu, trace.shape[0])
    err = np.abs(trace - ref).max() / np.abs(ref).max()
    assert err < 1e3 * tol, err
    assert sch.history.column("converged").all()


@pytest.mark.parametrize("mu", [10.0, 1.0, 0.01])
def test_aitken_converges(mu):
    sch, trace, _ = run(mu, acceleration={"kind": "aitken"})
    assert sch.history.column("converged").all()
    ref = reference(mu, trace.shape[0])
    assert np.abs(trace - ref).max() < 1e-2 * np.abs(ref).max()  # rtol 1e-4 per window


def fixed_point_eigenvalues(mu: float) -> np.ndarray:
    """Eigenvalues of the window's fixed-point map x -> x_tilde (numerical Jacobian)."""
    fluid, st = mock.pair(mu)
    sch = create_scheme(fluid, st, config())
    sch.initialize()
    T = sch.window
    fluid.checkpoint()
    st.checkpoint()
    d0f, v0f = sch.mapping.to_fluid(sch.d), sch.mapping.to_fluid(sch.v)

    def G(x):
        fluid.restore()
        st.restore()
        s = 2.0 * (x - sch.d) / T - sch.v  # Newmark-consistent velocity
        F, _ = sch._fluid_window(0.0, T, d0f, v0f, sch.mapping.to_fluid(x), sch.mapping.to_fluid(s))
        return sch._structure_window(0.0, T, sch.mapping.to_structure(F))[0][:, 1]

    x0 = np.zeros((st.n, 2))
    g0 = G(x0)
    J = np.empty((st.n, st.n))
    for j in range(st.n):
        x = x0.copy()
        x[j, 1] = 1e-6
        J[:, j] = (G(x) - g0) / 1e-6
    return np.linalg.eigvals(J)


def test_constant_relaxation_below_stability_limit_converges():
    mu = 3.0
    lam = fixed_point_eigenvalues(mu)
    assert (lam.real < 0).all() and np.abs(lam.imag).max() < 1e-6
    limit = 2.0 / (1.0 + np.abs(lam).max())
    sch, _, _ = run(mu, end=0.02, acceleration={"kind": "constant", "relaxation": 0.8 * limit})
    assert sch.history.column("converged").all()
    with pytest.raises((CouplingDivergedError, CouplingNotConvergedError)):
        run(mu, end=0.02, acceleration={"kind": "constant", "relaxation": min(1.0, 1.3 * limit)})


def test_iterations_per_window_vs_mass_ratio():
    """The added-mass stress test on the mock: where explicit coupling diverges, and how many
    iterations per window Aitken and IQN-ILS need (printed table)."""
    rows = []
    for mu in (10.0, 3.0, 1.0, 0.3, 0.1, 0.03, 0.01):
        row = [mu]
        try:
            run(mu, scheme="explicit")
            row.append("stable")
        except CouplingDivergedError:
            fluid, st = mock.pair(mu)
            sch = create_scheme(fluid, st, config(scheme="explicit"))
            with pytest.raises(CouplingDivergedError):
                sch.run(0.1)
            row.append(f"diverged @{sch.index}")
        for acc in ("aitken", "iqn-ils"):
            sch, _, _ = run(mu, acceleration={"kind": acc})
            it = sch.history.column("iterations")
            row += [it.mean(), it.max()]
        rows.append(row)
    print("\nmock added-mass problem, 100 windows, rtol 1e-4: iterations per window")
    print(
        f"{'m_a/m_s':>8} {'explicit':>14} {'aitken mean':>12} {'max':>4} {'iqn-ils mean':>13} {'max':>4}"
    )
    for r in rows:
        print(f"{r[0]:8.2f} {r[1]:>14} {r[2]:12.2f} {r[3]:4d} {r[4]:13.2f} {r[5]:4d}")
    by = {r[0]: r for r in rows}
    assert by[10.0][1].startswith("diverged") and by[0.01][1] == "stable"
    assert all(r[4] <= r[2] + 0.5 for r in rows)  # IQN-ILS needs no more than Aitken
    assert all(r[4] < 5 for r in rows)


def test_not_converged_stops_or_warns():
    kw = {
        "convergence": {
            "relative_tolerance": 1e-12,
            "absolute_tolerance": 1e-16,
            "max_iterations": 2,
        }
    }
    with pytest.raises(CouplingNotConvergedError, match=r"not converged after max_iterations = 2"):
        run(3.0, end=0.003, **kw)
    kw["convergence"]["on_divergence"] = "continue"
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        sch, _, _ = run(3.0, end=0.003, **kw)
    assert any(issubclass(w.category, CouplingWarning) for w in caught)
    rec = sch.history[-1]
    assert not rec.converged and "max_iterations" in rec.warning and rec.iterations == 2


def test_nan_stops_with_clear_message():
    fluid, st = mock.pair(1.0)
    sch = create_scheme(fluid, st, config())
    sch.run(0.002)
    fluid.load[3, 1] = np.nan
    with pytest.raises(CouplingDivergedError, match=r"fluid forces holds non-finite values"):
        sch.run(0.004)


def test_max_displacement_bound():
    with pytest.raises(CouplingDivergedError, match="max_displacement"):
        run(1.0, end=0.05, convergence={"max_displacement": 1e-3})


def test_window_and_subcycling():
    """Fluid max_dt 4e-4 in a 1e-3 window: 3 equal sub-steps; a 2e-3 window sub-cycles the
    structure (dt 1e-3) twice; a 5e-4 window gives the structure one step of 5e-4."""
    sch, _, st = run(1.0, end=0.004)
    assert (sch.history.column("fluid_substeps") == 3).all()
    assert (sch.history.column("structure_substeps") == 1).all()
    np.testing.assert_array_equal(sch.history.column("time"), [1e-3, 2e-3, 3e-3, 4e-3])
    sch, _, st = run(1.0, end=0.004, window=2e-3)
    assert (sch.history.column("structure_substeps") == 2).all()
    assert (sch.history.column("fluid_substeps") == 5).all()
    sch, _, st = run(1.0, end=0.002, window=5e-4)
    assert (sch.history.column("structure_substeps") == 1).all() and st.t == pytest.approx(0.002)


def test_records_and_energy_balance():
    """Implicit + conservative mapping: the structure's energy equals the work done on it
    (undamped, trapezoidal work, no structure sub-cycling) and the interface creates no
    energy beyond the tolerance; KFBI's force average does not keep the work."""
    tight = {"relative_tolerance": 1e-10, "absolute_tolerance": 1e-15}
    sch, _, _ = run(1.0, end=0.05, convergence=tight)
    h = sch.history_arrays()
    for key in ("time", "iterations", "residual", "work_structure", "energy_imbalance"):
        assert key in h and h[key].shape == (50,)
    e_scale = np.abs(h["structure_energy"]).max()
    assert np.abs(h["energy_imbalance"]).max() < 1e-9 * e_scale
    assert np.abs(h["interface_work_error"]).max() < 1e-6 * e_scale
    row = sch.history[-1].results_row()
    assert {"residual_abs", "work_structure", "structure_energy"} <= set(row)
    sch_k, _, _ = run(1.0, end=0.05, convergence=tight, mapping={"kind": "kfbi", "radius": 0.06})
    hk = sch_k.history_arrays()
    assert np.abs(hk["interface_work_error"]).max() > 1e-3 * e_scale


class MotionRecordingFluid(mock.AddedMassFluid):
    """The mock fluid, keeping the displacement it was moved to and its force after every
    accepted step (checkpoint/restore drop the steps of rejected iterations)."""

    def __init__(self, structure, mass_ratio: float, dt: float) -> None:
        super().__init__(structure, mass_ratio, dt=dt)
        self.track = [(self.d.copy(), self.F.copy())]

    def advance(self, dt: float) -> float:
        done = super().advance(dt)
        self.track.append((self.d.copy(), self.F.copy()))
        return done

    def checkpoint(self) -> None:
        super().checkpoint()
        self._n_track = len(self.track)

    def restore(self) -> None:
        super().restore()
        del self.track[self._n_track :]

    def own_work(self) -> float:
        """Trapezoidal work of its forces on its own interface points' motion, step by step."""
        return sum(
            0.5 * float(np.vdot(F0 + F1, d1 - d0))
            for (d0, F0), (d1, F1) in zip(self.track[:-1], self.track[1:], strict=True)
        )


@pytest.mark.parametrize(
    "kw",
    [
        {"scheme": "explicit"},
        {"scheme": "implicit", "convergence": {"relative_tolerance": 1e-2}},
    ],
    ids=["explicit", "implicit-rtol-1e-2"],
)
def test_fluid_work_is_on_the_motion_the_fluid_made(kw):
    """W_f is the work of the fluid's forces on the motion its interface points made: they end a
    window at the accepted iterate H x_n, not at the structure's answer H d_n, and start the next
    from there. Measured here by the fluid itself (one fluid step per window, so the window
    trapezoid is its own); with a residual left in every window (explicit, loose tolerance)
    sum (W_s - W_f) must equal the structure's work minus the fluid's own to round-off (it did
    not when W_f started each window at H d_n: 2-3 % of the structure's energy)."""
    st = mock.SpringMassStructure()
    fluid = MotionRecordingFluid(st, 1.0, dt=st.dt)
    sch = create_scheme(fluid, st, config(**kw))
    sch.run(0.2)
    h = sch.history_arrays()
    assert (h["fluid_substeps"] == 1).all() and (h["residual_abs"] > 0).any()
    e_scale = np.abs(h["structure_energy"] - sch.energy0).max()
    created = h["work_structure_total"][-1] - fluid.own_work()
    assert abs(h["interface_work_error"][-1] - created) < 1e-9 * e_scale
    assert abs(created) < 2e-3 * e_scale  # what these settings create: see docs/coupler.md


@pytest.mark.parametrize(
    ("relative_to", "rtols"),
    [("displacement", (1e-2, 1e-4, 1e-8)), ("window_motion", (1e-1, 1e-2, 1e-3))],
)
def test_interface_work_error_falls_with_the_tolerance(relative_to, rtols):
    """The interface work error is the work of the residual left in the accepted iterates: it
    falls with the relative tolerance instead of sitting at round-off or at a
    tolerance-independent level. Mock, as fractions of the structure's largest energy:
    displacement 5.3e-4, 5.7e-7, 1.7e-9 at 1e-2, 1e-4, 1e-8; window_motion 1.2e-3, 2.3e-4,
    1.0e-6 at 1e-1, 1e-2, 1e-3. IQN-ILS with the accepted iterations' columns nearly solves the
    linear mock once it has them, so from 1e-4 on the accepted residual lies well below the
    tolerance (median 1.7e-6 at 1e-4, 5e-7 at 1e-6: the error falls in steps, not per decade)."""
    err = []
    for rtol in rtols:
        conv = {"relative_tolerance": rtol, "absolute_tolerance": 1e-15, "relative_to": relative_to}
        sch, _, _ = run(1.0, end=0.2, convergence=conv)
        h = sch.history_arrays()
        e_scale = np.abs(h["structure_energy"] - sch.energy0).max()
        err.append(np.abs(h["interface_work_error"]).max() / e_scale)
    assert err[0] < 2e-3
    assert err[1] < err[0] / 3 and err[2] < err[1] / 3


class ShrinkingFluid(mock.AddedMassFluid):
    """Drops its last interface particle after a few windows (a changing particle set)."""

    def __init__(self, *a, **kw):
        super().__init__(*a, **kw)
        self.calls = 0

    def interface(self):
        self.calls += 1
        if self.calls == 4:
            keep = slice(0, self.mesh.n_points - 1)
            self.mesh = InterfaceMesh(self.mesh.points[keep], self.mesh.normals[keep])
            for name in ("m", "load", "d", "v_in", "v_old", "F"):
                setattr(self, name, getattr(self, name)[keep].copy())
        return self.mesh


def test_mapping_rebuilt_when_particles_change():
    st = mock.SpringMassStructure()
    fluid = ShrinkingFluid(st, 1.0)
    sch = create_scheme(fluid, st, config())
    sch.run(0.006)
    assert sch.mapping.builds == 2 and sch.mapping.fluid.n_points == fluid.mesh.n_points


@pytest.mark.parametrize(
    ("acc", "extra"),
    [
        ({"kind": "iqn-ils"}, {}),
        ({"kind": "iqn-imvj"}, {}),
        ({"kind": "iqn-imvj", "restart": "RS-SVD", "chunk_size": 3}, {}),
        ({"kind": "iqn-imvj", "restart": "RS-LS", "chunk_size": 3}, {}),
        # the linear predictor needs the window before: d_n-1 and T_n-1 are in the checkpoint
        ({"kind": "iqn-imvj"}, {"predictor": "linear"}),
    ],
)
def test_restart_continues_bit_for_bit(acc, extra):
    cfg = config(acceleration=acc, **extra)
    fluid, st = mock.pair(3.0)
    sch = create_scheme(fluid, st, cfg)
    sch.run(0.01)
    saved = copy.deepcopy((fluid, st, sch.state_dict()))
    sch.run(0.02)
    f2, s2, state = saved
    sch2 = create_scheme(f2, s2, cfg)
    sch2.initialize()
    sch2.load_state_dict(state)
    sch2.run(0.02)
    assert sch2.d.tobytes() == sch.d.tobytes() and s2.u.tobytes() == st.u.tobytes()
    assert [r.iterations for r in sch2.history] == [r.iterations for r in sch.history[10:]]


def test_real_structure_participant_with_mock_fluid():
    """The FEM beam of structure_fem coupled to the added-mass mock: the protocols fit, the
    implicit scheme converges and the damped structure gains no energy beyond the work."""
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).parents[1] / "structure_fem"))
    structure_cases = pytest.importorskip("structure_cases")
    from mpsfem.structure_fem.participant import StructureParticipant

    st = StructureParticipant(structure_cases.section([structure_cases.BEAM]))
    m_beam = 1100.0 * 0.04 * 0.25
    fluid = mock.AddedMassFluid(
        st, mass_ratio=2.0, spacing=0.005, pressure=200.0, dt=4e-5, structure_mass=m_beam
    )
    sch = create_scheme(fluid, st, config())
    sch.run(0.005)
    h = sch.history_arrays()
    assert h["converged"].all() and h["iterations"].max() < 10
    tip = np.abs(st.read("displacement")).max()
    assert 0 < tip < 1e-2
    assert (h["energy_imbalance"] < 1e-9 * max(1e-12, np.abs(h["structure_energy"]).max())).all()


def test_scheme_names_and_defaults():
    fluid, st = mock.pair(1.0)
    sch = create_scheme(fluid, st)
    assert isinstance(sch, ImplicitScheme) and sch.acceleration.kind == "iqn-ils"
    assert sch.mapping.kind == "shape-function"
    sch.initialize()
    assert sch.window == st.max_dt()


def test_window_motion_measure_scales_by_the_windows_motion():
    """relative_to = "window_motion": the residual over rms(x_tilde - d_n) instead of rms(x_tilde)
    (a window that moves the interface by 1 % of its displacement: 100 times stricter)."""
    d0 = np.full(8, 1.0)
    x_t = d0 + 0.01
    x = x_t + 1e-4
    whole = ResidualCriterion(1e-3, 1e-12)
    window = ResidualCriterion(1e-3, 1e-12, relative_to="window_motion")
    assert whole.measure(x, x_t, d0)[0] == pytest.approx(1e-4 / 1.01, rel=1e-12)
    assert window.measure(x, x_t, d0)[0] == pytest.approx(1e-2, rel=1e-9)
    with pytest.raises(ValueError, match="x_start"):
        window.measure(x, x_t)
    with pytest.raises(ValueError, match="relative_to"):
        ResidualCriterion(1e-3, 1e-12, relative_to="velocity")


@pytest.mark.parametrize(
    "scheme, kw, mu",
    [
        ("implicit", {"convergence": {"max_displacement": 1e-3}}, 0.3),
        ("explicit", {"convergence": {"max_displacement": 1e-3}}, 0.3),
        ("explicit", {}, 10.0),  # the added-mass instability detector
    ],
)
def test_a_rejected_window_leaves_the_scheme_at_the_last_accepted_one(scheme, kw, mu):
    """The max_displacement check and the explicit detector judge the candidate window before
    anything is accepted: after the CouplingDivergedError the scheme's time, index, d, v, F_s,
    the accelerator's window counter and the detector are those of the last accepted window."""
    fluid, st = mock.pair(mu)
    sch = create_scheme(fluid, st, config(scheme=scheme, **kw))
    accepted = {}

    def keep(rec):
        accepted.update(d=sch.d.copy(), v=sch.v.copy(), F_s=sch.F_s.copy())
        accepted["detector"] = copy.deepcopy(sch.detector.__dict__)

    with pytest.raises(CouplingDivergedError):
        sch.run(0.5, on_window=keep)
    assert len(sch.history) > 2
    last = sch.history[-1]
    assert sch.t == last.time and sch.index == len(sch.history) == last.index + 1
    for k in ("d", "v", "F_s"):
        assert np.array_equal(getattr(sch, k), accepted[k]), k
    if "max_displacement" in kw.get("convergence", {}):
        assert np.abs(sch.d).max() <= 1e-3
    if scheme == "implicit":
        assert sch.acceleration.window == sch.index
    else:
        det = sch.detector.__dict__
        assert det["_log"] == accepted["detector"]["_log"]
        assert np.array_equal(det["_prev"], accepted["detector"]["_prev"])


def test_iqn_ils_learns_from_every_iteration_of_an_accepted_window():
    """The scheme hands the accepted iteration to the accelerator (iterations_converged) before
    ending the window: a window of k iterations leaves k - 1 columns (compute() sees k - 1
    iterations and makes k - 2; the last comes from the accepted one), tagged with it (the
    filter may have removed some for good: it counts them)."""
    fluid, st = mock.pair(3.0)
    sch = create_scheme(fluid, st, config(convergence={"relative_tolerance": 1e-8}))
    rec = sch.advance_window()
    assert rec.converged and rec.iterations >= 3
    acc = sch.acceleration
    assert len(acc.V) + acc.filtered == rec.iterations - 1
    assert len(acc.Ws["velocity"]) == len(acc.V)
    assert acc.tags == [0] * len(acc.V) and acc.window == 1


def test_accept_unconverged_best_takes_the_nearest_iterate_and_re_runs_it():
    """accept_unconverged = "best": unrelaxed iterations at added / structure mass 3 diverge
    (the mock's residual grows 1.6-1.8 times per iteration), so of 5 iterations the first (the
    predictor) is nearest the criterion and the last the farthest. "best" accepts the first,
    re-run by both participants: the window ends bit for bit as a run that stops after one
    iteration; "last" (the default) accepts the fifth, with its about 9 times larger residual."""
    conv = {"relative_tolerance": 1e-12, "absolute_tolerance": 1e-16, "on_divergence": "continue"}
    acc = {"kind": "constant", "relaxation": 1.0}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", CouplingWarning)
        one, tr_one, _ = run(
            3.0, end=0.002, acceleration=acc, convergence=conv | {"max_iterations": 1}
        )
        last, tr_last, _ = run(
            3.0, end=0.002, acceleration=acc, convergence=conv | {"max_iterations": 5}
        )
        best, tr_best, _ = run(
            3.0,
            end=0.002,
            acceleration=acc,
            convergence=conv | {"max_iterations": 5, "accept_unconverged": "best"},
        )
    np.testing.assert_array_equal(tr_best, tr_one)  # the accepted pair is iteration 1's own
    np.testing.assert_array_equal(best.history.column("residual"), one.history.column("residual"))
    assert (best.history.column("iterations") == 6).all()  # 5 + the re-run
    assert "accepted iteration 1" in best.history[0].warning
    assert (last.history.column("iterations") == 5).all()
    assert last.history[0].residual_abs > 5.0 * best.history[0].residual_abs
    assert not np.array_equal(tr_last, tr_one)


class _SwitchingFluid(mock.AddedMassFluid):
    """Added-mass fluid with a frozen-flag hook: at its first converged iterate it asks for a
    re-decision and its added mass grows 30-fold (a new fixed-point map under which unrelaxed
    iterations diverge)."""

    def __init__(self, structure) -> None:
        super().__init__(structure, mass_ratio=0.1)
        self.freeze = self
        self.k = 0  # iteration of the current window
        self.k_switch = None

    def checkpoint(self) -> None:
        super().checkpoint()
        self.k = 1

    def restore(self) -> None:
        super().restore()
        self.k += 1

    def request_redecision(self) -> bool:
        if self.k_switch is not None:
            return False
        self.k_switch = self.k
        self.m = 30.0 * self.m
        return True


def test_accept_unconverged_best_forgets_the_iterates_of_an_earlier_map():
    """A re-decision of the fluid's flags changes the map: "best" must choose among the
    iterates after it (the converged iterate before it cannot be re-run under the old map)."""
    fluid_st = mock.SpringMassStructure()
    fluid = _SwitchingFluid(fluid_st)
    cfg = config(
        acceleration={"kind": "constant", "relaxation": 1.0},
        convergence={
            "relative_tolerance": 1e-6,
            "max_iterations": 20,
            "on_divergence": "continue",
            "accept_unconverged": "best",
        },
    )
    sch = create_scheme(fluid, fluid_st, cfg)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", CouplingWarning)
        sch.run(1e-3)
    rec = sch.history[0]
    assert fluid.k_switch is not None and fluid.k_switch < 20
    assert not rec.converged and rec.iterations == 21
    chosen = int(rec.warning.split("accepted iteration ")[1].split(" ")[0])
    assert chosen > fluid.k_switch, (chosen, fluid.k_switch)
    print(f"re-decided at iteration {fluid.k_switch}, accepted iteration {chosen}")
