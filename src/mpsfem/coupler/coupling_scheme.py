"""Serial coupling schemes: explicit (staggered) and implicit (iterated), as in preCICE.

Roles (fixed, as in preCICE's serial schemes): the **fluid is the first participant**, the
**structure the second**. The scheme runs in the fluid's process; it

* maps on the fluid side: structure displacement/velocity -> fluid points (consistent), fluid
  forces -> structure nodes (conservative, or the thesis's KFBI);
* accelerates the second participant's data on its own mesh: the structure's window-end
  interface displacement (primary: the residual is measured on it) and velocity (secondary,
  same linear combination);
* talks to the structure directly (``inproc``) or through a
  :class:`~mpsfem.coupler.remote.RemoteParticipant` (``mpi``, ``zenoh``) — the same arithmetic
  on the same bits either way.

One window [t_n, t_n + T] (:meth:`CouplingScheme.advance_window`):

1. Predict the window-end interface state x = d_n + T v_n, s = v_n (d, v the structure's
   accepted displacement and velocity at t_n). For Newmark's average-acceleration rule this pair
   is consistent, and it is the first iterate of the implicit scheme (``coupling.predictor``:
   "constant" x = d_n, "linear" x = d_n + T (d_n - d_n-1) / T_n-1, as preCICE's extrapolation
   orders 0 and 1).
2. Fluid: sub-cycles from t_n to t_n + T in equal steps (``time_window.subcycle``), given at each
   sub-step end the displacement and velocity interpolated linearly between (d_n, v_n) and
   (x, s), mapped to its points (``interface_velocity = "displacement_rate"``: the velocity is
   instead the points' own, (H x - H d_n) / T, constant in the window); its forces are sampled
   after every sub-step and averaged over the window (``force_sampling = "mean"``) or taken at
   the end.
3. Structure: the mapped force, linearly interpolated from the previous window's value when it
   sub-cycles; answers x_tilde, s_tilde at t_n + T.
4. Explicit: accept. Implicit: residual r = x_tilde - x (``convergence``); if converged accept,
   else restore both participants to t_n and iterate with the accelerated (x, s).

Records (:class:`WindowRecord`, :attr:`CouplingScheme.history`): per window its end time,
iterations, residual, sub-step counts, timings, and an interface energy balance: the work of the
mapped forces on the structure, W_s = 1/2 (F_n + F_n+1) . (d_n+1 - d_n) (the trapezoidal work
that Newmark's average-acceleration rule conserves), the work of the fluid's forces on the motion
the fluid was given, W_f = 1/2 (F_f,n + F_f,n+1) . (H x_n+1 - H x_n) (same rule on the fluid
points, x_n the accepted iterate of window n: the fluid's interface points end window n at H x_n,
not at H d_n, and its first sub-step of window n + 1 moves them on from there), and the
structure's energy if it reports one. Cumulative E_s - E_s(0) - sum W_s (energy the structure
gained beyond the work done on it; <= 0 with damping) and sum (W_s - W_f) (energy the interface
created) tell whether a coupling setting injects energy. With a conservative mapping
(F_s = H^T F_f) W_s - W_f = 1/2 (F_n + F_n+1) . (r_n+1 - r_n), r = d - x the accepted
residual: zero for an exact fixed point, non-zero for KFBI, explicit coupling and every window
accepted with a residual, above all those accepted at their first iterate (the predictor).
"""

from __future__ import annotations

import math
import time
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np

from mpsfem.coupler import SCHEMES
from mpsfem.coupler.acceleration import Acceleration, create_acceleration
from mpsfem.coupler.convergence import (
    ForceErrorCriterion,
    InstabilityDetector,
    ResidualCriterion,
    check_finite,
)
from mpsfem.coupler.errors import (
    CouplingDivergedError,
    CouplingNotConvergedError,
    CouplingWarning,
)
from mpsfem.coupler.mapping import Mapping, create_mapping
from mpsfem.coupler.participant import (
    DISPLACEMENT,
    FORCES,
    VELOCITY,
    as_interface_mesh,
    energy_of,
)
from mpsfem.coupler.time_window import TIME_EPS, interpolate, subcycle
from mpsfem.scenario.coupling import CouplingSection

__all__ = [
    "CouplingHistory",
    "CouplingScheme",
    "ExplicitScheme",
    "ImplicitScheme",
    "WindowRecord",
    "create_scheme",
]

#: an implicit window whose residual grows this many times above its first one has diverged
DIVERGENCE_GROWTH = 1e4
#: an accelerated iterate that a participant rejects (its ``iterate_errors``: a fluid particle
#: thrown out of the domain by an interface jump, a structure's Newton failing) is retried at RETREAT of its step from the last
#: iterate the fluid completed, at most MAX_RETREATS times an iteration; then the error stands
RETREAT = 0.25
MAX_RETREATS = 4


@dataclass
class WindowRecord:
    """What happened in one coupling window."""

    index: int
    time: float  # window end, s
    window: float  # length, s
    iterations: int
    residual: float  # relative residual of the accepted iterate (see convergence)
    residual_abs: float  # rms(x_tilde - x), m
    converged: bool
    fluid_substeps: int  # in the accepted iteration
    structure_substeps: int
    work_structure: float  # J (J/m in 2D)
    work_fluid: float
    structure_energy: float  # NaN if the structure reports none
    warning: str = ""
    timings: dict[str, float] = field(default_factory=dict)  # s, summed over iterations
    # fictitious force error / load of the accepted iterate (ForceErrorCriterion); NaN: no
    # fictitious mass acting
    force_error: float = float("nan")
    # times the structure's fictitious-mass wet set grew inside the window (its fixed-point
    # map changed; fictitious_wet_update = "grow"); NaN: a structure whose set cannot grow
    set_growths: float = float("nan")

    def results_row(self) -> dict[str, float]:
        """Scalars for ``ResultsFile.append_coupling(time, iterations, residual, **extra)``
        (``fictitious_force_error`` only from a window with a fictitious mass acting)."""
        extra = {} if np.isnan(self.force_error) else {"fictitious_force_error": self.force_error}
        if not np.isnan(self.set_growths):
            extra["fictitious_set_growths"] = self.set_growths
        return extra | {
            "residual_abs": self.residual_abs,
            "converged": float(self.converged),
            "window": self.window,
            "fluid_substeps": float(self.fluid_substeps),
            "structure_substeps": float(self.structure_substeps),
            "work_structure": self.work_structure,
            "work_fluid": self.work_fluid,
            "structure_energy": self.structure_energy,
        }


class CouplingHistory(list):
    """The :class:`WindowRecord` of every window, with column access."""

    def column(self, name: str) -> np.ndarray:
        if name in WindowRecord.__dataclass_fields__:
            return np.array([getattr(r, name) for r in self])
        return np.array([r.timings.get(name, 0.0) for r in self])

    def as_arrays(self, energy0: float = float("nan")) -> dict[str, np.ndarray]:
        """Columns (time, iterations, residual, ...) plus the cumulative energy balance:
        ``work_structure_total``, ``energy_imbalance`` = E_s - E_s(0) - sum W_s and
        ``interface_work_error`` = sum (W_s - W_f)."""
        out = {
            k: self.column(k)
            for k, v in WindowRecord.__dataclass_fields__.items()
            if k not in ("warning", "timings")
        }
        ws = np.cumsum(out["work_structure"]) if len(self) else np.zeros(0)
        out["work_structure_total"] = ws
        out["energy_imbalance"] = out["structure_energy"] - energy0 - ws
        out["interface_work_error"] = np.cumsum(out["work_structure"] - out["work_fluid"])
        return out


class CouplingScheme:
    """Serial coupling of a fluid (first) and a structure (second) participant.

    Parameters
    ----------
    fluid, structure:
        Participants (:class:`~mpsfem.coupler.participant.Participant`); the structure may be a
        :class:`~mpsfem.coupler.remote.RemoteParticipant`.
    config:
        The ``[coupling]`` section (:class:`~mpsfem.scenario.coupling.CouplingSection`);
        default: all defaults.
    mapping, acceleration:
        Pre-built components (default: created from ``config``).
    log:
        Callable for warnings (default: :func:`warnings.warn` with :class:`CouplingWarning`).
    """

    kind: ClassVar[str]
    implicit: ClassVar[bool]

    def __init__(
        self,
        fluid,
        structure,
        config: CouplingSection | None = None,
        *,
        mapping: Mapping | None = None,
        acceleration: Acceleration | None = None,
        log: Callable[[str], None] | None = None,
    ) -> None:
        self.config = config if config is not None else CouplingSection(scheme=self.kind)
        self.fluid, self.structure = fluid, structure
        self.mapping = mapping if mapping is not None else create_mapping(self.config.mapping)
        if self.implicit and acceleration is None:
            acceleration = create_acceleration(self.config.acceleration)
        self.acceleration = acceleration
        self.criterion = ResidualCriterion.from_section(self.config.convergence)
        self.force_criterion = ForceErrorCriterion.from_section(self.config.convergence)
        # the largest load scale S of an accepted window so far (ForceErrorCriterion)
        self.force_scale_peak = 0.0
        self.log = log
        self.history = CouplingHistory()
        self.retreats = 0  # rejected iterates retried, over the run
        self.detector = InstabilityDetector(floor=self.config.convergence.absolute_tolerance)
        self.t = self.t0 = 0.0
        self.index = 0
        self.window: float | None = None
        self.initialized = False

    # ------------------------------------------------------------------ set-up
    def initialize(self, t0: float = 0.0) -> None:
        """Exchange meshes, build the mapping, hand both participants their initial data."""
        self.t = self.t0 = float(t0)
        self.index = 0
        self.structure_mesh = as_interface_mesh(self.structure.interface())
        fluid_mesh = as_interface_mesh(self.fluid.interface())
        self.mapping.build(fluid_mesh, self.structure_mesh)
        self.window = (
            float(self.config.window)
            if self.config.window is not None
            else float(self.structure.max_dt())
        )
        self.F_f = self._read_forces()
        # the structure's displacement is not known yet: the reference configuration
        self.F_s = self.mapping.forces_to_structure(
            self.F_f, np.zeros_like(self.structure_mesh.points)
        )
        check_finite("initial data", forces=self.F_s)
        # the initial forces first: the structure rebuilds its start state under them (a static
        # start solves K u0 = F_self + F_fluid), so its displacement is read only afterwards
        self.structure.write(FORCES, self.F_s)
        self.d, self.v = read_outputs(self.structure, (DISPLACEMENT, VELOCITY))
        shape = self.structure_mesh.points.shape
        for name, a in ((DISPLACEMENT, self.d), (VELOCITY, self.v)):
            if a.shape != shape:
                raise ValueError(f"structure {name} of shape {a.shape}, expected {shape}")
        check_finite("initial data", displacement=self.d, velocity=self.v)
        self.d_f = self.mapping.displacement_to_fluid(self.d)  # where the fluid's points are
        self.d_prev, self.T_prev = self.d.copy(), math.nan  # the window before (predictor)
        self.fluid.write(DISPLACEMENT, self.d_f)
        self.fluid.write(VELOCITY, self.mapping.velocity_to_fluid(self.v, self.d))
        self.energy0 = energy_of(self.structure)
        self.detector.reset()
        self.initialized = True

    def _read_forces(self) -> np.ndarray:
        F = np.array(self.fluid.read(FORCES), dtype=np.float64)
        if F.shape != self.mapping.fluid.points.shape:
            raise ValueError(
                f"fluid forces of shape {F.shape}, expected {self.mapping.fluid.points.shape}"
            )
        return F

    # ------------------------------------------------------------------ driving
    def run(
        self, end_time: float, on_window: Callable[[WindowRecord], None] | None = None
    ) -> CouplingHistory:
        """Advance window by window to ``end_time``; ``on_window(record)`` after each."""
        if not self.initialized:
            self.initialize()
        while end_time - self.t > TIME_EPS * self.window:
            t_end = self.t0 + (self.index + 1) * self.window  # no accumulated round-off
            if t_end > end_time - TIME_EPS * self.window:
                t_end = end_time
            rec = self.advance_window(t_end)
            if on_window is not None:
                on_window(rec)
        return self.history

    def advance_window(self, t_end: float | None = None) -> WindowRecord:
        """One coupling window from the current time to ``t_end`` (default: one window)."""
        if not self.initialized:
            self.initialize()
        t0 = self.t
        t1 = self.t0 + (self.index + 1) * self.window if t_end is None else float(t_end)
        T = self.window_length(t0, t1)
        timings = {"fluid": 0.0, "structure": 0.0, "mapping": 0.0, "acceleration": 0.0}
        tic = time.perf_counter()
        fluid_mesh = as_interface_mesh(self.fluid.interface())
        F_f_prev, d_f_start = self.F_f, self.d_f
        if self.mapping.needs_rebuild(fluid_mesh):
            self.mapping.build(fluid_mesh, self.structure_mesh)
            F_f_prev = d_f_start = None  # data of the old particle set do not fit the new one
        d_f0 = self.mapping.displacement_to_fluid(self.d)
        if d_f_start is None:
            d_f_start = d_f0
        v_f0 = self.mapping.velocity_to_fluid(self.v, self.d)
        timings["mapping"] += time.perf_counter() - tic

        x = self._predict(T)
        s = self.v.copy()
        if self.implicit:
            self.fluid.checkpoint()
            self.structure.checkpoint()
            self.acceleration.start_window()
        cv = self.config.convergence
        max_it = cv.max_iterations if self.implicit else 1
        first_abs = None
        warning = ""
        rejects = tuple(getattr(self.fluid, "iterate_errors", ())) + tuple(
            getattr(self.structure, "iterate_errors", ())
        )
        last = None  # (x, s) of the last iterate the fluid completed in this window
        # retreat_predictor: a rejected first iterate (the predictor) retreats towards the
        # window's start (d_n, v_n) instead of ending the run
        start = (self.d, self.v) if cv.retreat_predictor else None
        # optional structure hook: the interface iterate its forces answer to (the fictitious
        # mass of structure_fem needs it under acceleration; docs/coupler.md)
        set_iterate = getattr(self.structure, "set_iterate", None) if self.implicit else None
        # optional structure hook: the force its fictitious mass leaves (ForceErrorCriterion)
        force_error = (
            getattr(self.structure, "fictitious_force_error", None) if self.implicit else None
        )
        # optional structure hook: how often its wet set (its fixed-point map) grew in the window
        growths = getattr(self.structure, "fictitious_set_growths", None) if self.implicit else None
        grown = float("nan")
        # accept_unconverged = "best": (merit, iteration, residual, x, s) of the iterate nearest
        # the criteria so far (merit max(residual / rtol, force ratio / force tolerance))
        keep_best = cv.accept_unconverged == "best" and cv.on_divergence == "continue"
        best = None
        f_ratio = float("nan")
        f_scale = 0.0
        for k in range(1, max_it + 1):
            if k > 1:
                self.fluid.restore()
                self.structure.restore()
            retreats = 0
            while True:
                try:
                    d_f1, F_f1, n_f, F_s1, x_t, s_t, n_s = self._evaluate(
                        t0, t1, d_f0, v_f0, x, s, set_iterate, timings
                    )
                    break
                except rejects as exc:
                    # the accelerated iterate was one a participant cannot take (e.g. an
                    # interface jump far beyond the fluid's Courant limit, or the forces it
                    # raised beyond the structure's Newton): step back towards the last iterate
                    # both completed, along the same direction (a backtracking line search)
                    anchor = last if last is not None else start
                    if anchor is None or retreats >= MAX_RETREATS:
                        raise
                    retreats += 1
                    self.retreats += 1
                    self.fluid.restore()
                    self.structure.restore()
                    x = anchor[0] + RETREAT * (x - anchor[0])
                    s = anchor[1] + RETREAT * (s - anchor[1])
                    self._warn(
                        f"coupling window {self.index} ending at t = {t1:.9g} s, iteration {k}: "
                        f"the accelerated iterate was rejected ({type(exc).__name__}: "
                        f"{str(exc)[:200]}); retrying {RETREAT:g} of the step from the "
                        + ("last completed iterate" if last is not None else "window's start")
                        + f" (retreat {retreats} of {MAX_RETREATS})"
                    )
            last = (x.copy(), s.copy())
            g = growths() if growths is not None else None
            if g is not None:
                if g > (0 if np.isnan(grown) else grown):
                    # the structure's map changed in this iteration: the secant pairs of the
                    # earlier ones belong to another map (preCICE: an accelerator's history
                    # holds for one fixed-point map)
                    self.acceleration.restart_window()
                    best = None  # and the best iterate so far another map: this one is first
                grown = float(g)
            where = f"coupling window {self.index} ending at t = {t1:.9g} s, iteration {k}"
            residual, r_abs, got, f_scale, f_ratio = self._measure(
                where, F_f1, x, x_t, s_t, force_error
            )
            if not self.implicit:
                converged = True
                break
            f_ok = got is None or self.force_criterion.converged(f_ratio)
            if keep_best:  # how far this iterate is from both criteria (1: just meets them)
                merit = residual / cv.relative_tolerance
                if got is not None and self.force_criterion.tolerance is not None:
                    merit = max(merit, f_ratio / self.force_criterion.tolerance)
                if best is None or merit < best[0]:
                    best = (merit, k, residual, x.copy(), s.copy())
            if f_ok and self.criterion.converged(residual, k):
                if not (k < max_it and self._redecide_flags()):
                    converged = True
                    break
                best = None  # the fluid's flags were re-decided: the iterates so far had others
            if k == max_it:
                converged = False
                why = (
                    f"residual {residual:.3g} (tolerance {cv.relative_tolerance:g}; rms "
                    f"|x_tilde - x| = {r_abs:.3g} m)"
                )
                if not f_ok:
                    why += (
                        f", fictitious force error {f_ratio:.3g} of the load (tolerance "
                        f"{self.force_criterion.tolerance:g})"
                    )
                msg = (
                    f"{where}: not converged after max_iterations = {max_it}: {why}. "
                    "Raise coupling.convergence."
                    "max_iterations, use a stronger acceleration (iqn-ils) or a shorter window, "
                    'or set coupling.convergence.on_divergence = "continue"'
                )
                if cv.on_divergence == "stop":
                    raise CouplingNotConvergedError(msg)
                if keep_best and best[1] != k:
                    # accept_unconverged = "best": the iterate nearest the criteria, not the
                    # last (an accelerator cycling across a discontinuity of the fluid's map,
                    # e.g. a wall that is dry at one iterate and wet at the next, may end on
                    # its worst one); both participants re-run it, so the accepted pair is
                    # that iterate's own
                    self.fluid.restore()
                    self.structure.restore()
                    x, s = best[3], best[4]
                    d_f1, F_f1, n_f, F_s1, x_t, s_t, n_s = self._evaluate(
                        t0, t1, d_f0, v_f0, x, s, set_iterate, timings
                    )
                    residual, r_abs, got, f_scale, f_ratio = self._measure(
                        where, F_f1, x, x_t, s_t, force_error
                    )
                    msg += (
                        f"; accepted iteration {best[1]} (residual {best[2]:.3g}), the nearest "
                        f"the criteria, re-evaluated: residual {residual:.3g}"
                        + ("" if got is None else f", fictitious force error {f_ratio:.3g}")
                    )
                    k += 1  # the re-evaluation is one more iteration of both participants
                warning = msg
                self._warn(msg)
                break
            if first_abs is None:
                first_abs = r_abs
            elif r_abs > DIVERGENCE_GROWTH * first_abs and r_abs > cv.absolute_tolerance:
                raise CouplingDivergedError(
                    f"{where}: the coupling iterations diverge: residual grew from "
                    f"{first_abs:.3g} m to {r_abs:.3g} m rms "
                    f"({self.config.acceleration.kind} acceleration); try iqn-ils, a smaller "
                    "initial relaxation or a shorter window"
                )
            tic = time.perf_counter()
            xn, sec = self.acceleration.compute(
                x.reshape(-1), x_t.reshape(-1), {VELOCITY: (s.reshape(-1), s_t.reshape(-1))}
            )
            x, s = xn.reshape(x.shape), sec[VELOCITY].reshape(s.shape)
            timings["acceleration"] += time.perf_counter() - tic

        # check the candidate window before accepting anything: after a CouplingError the
        # scheme (t, d, v, F_s, history, acceleration, detector) is that of the last window
        if cv.max_displacement is not None:
            dmax = float(np.abs(x_t).max())
            if dmax > cv.max_displacement:
                raise CouplingDivergedError(
                    f"coupling window {self.index} ending at t = {t1:.9g} s: interface "
                    f"displacement {dmax:.3g} m exceeds coupling.convergence.max_displacement = "
                    f"{cv.max_displacement:g} m"
                )
        if not self.implicit:
            why = self.detector.check(x_t - x)
            if why is not None:
                raise CouplingDivergedError(
                    f"explicit coupling diverges at window {self.index} (t = {t1:.9g} s): {why}. "
                    'Use scheme = "implicit" (with iqn-ils or aitken acceleration)'
                )
            self.detector.commit()

        # accept the window
        if self.implicit:
            tic = time.perf_counter()
            self.acceleration.iterations_converged(
                x.reshape(-1), x_t.reshape(-1), {VELOCITY: (s.reshape(-1), s_t.reshape(-1))}
            )
            self.acceleration.end_window()
            timings["acceleration"] += time.perf_counter() - tic
        work_s = 0.5 * float(np.vdot(self.F_s + F_s1, x_t - self.d))
        # the fluid's points moved from where the last window left them (the accepted iterate
        # H x_n, d_f_start), not from H d_n: the residual jump is part of their motion
        if F_f_prev is None:
            work_f = float(np.vdot(F_f1, d_f1 - d_f_start))
        else:
            work_f = 0.5 * float(np.vdot(F_f_prev + F_f1, d_f1 - d_f_start))
        self.d_prev, self.T_prev = self.d, T
        self.d, self.v = x_t, s_t
        self.force_scale_peak = max(self.force_scale_peak, f_scale)
        self.d_f = d_f1
        self.F_s, self.F_f = F_s1, F_f1
        self.t = t1
        energy = energy_of(self.structure)
        rec = WindowRecord(
            index=self.index,
            time=t1,
            window=T,
            iterations=k,
            residual=residual,
            residual_abs=r_abs,
            converged=converged,
            fluid_substeps=n_f,
            structure_substeps=n_s,
            work_structure=work_s,
            work_fluid=work_f,
            structure_energy=energy,
            warning=warning,
            timings=timings,
            force_error=f_ratio,
            set_growths=grown,
        )
        self.history.append(rec)
        self.index += 1
        return rec

    def _redecide_flags(self) -> bool:
        """At a converged iterate: True when the fluid's discrete flags, frozen in the window,
        are not the iterate's own and it re-decides them from it (the window goes on; see
        ``fluid_mps.surface_freeze``, rule "settled"). A fluid without frozen flags: False."""
        freeze = getattr(self.fluid, "freeze", None)
        request = getattr(freeze, "request_redecision", None)
        if request is None or not request():
            return False
        # the iterations so far solved another discrete problem: their secant pairs would
        # mislead the accelerator on the new one
        self.acceleration.restart_window()
        return True

    def window_length(self, t0: float, t1: float) -> float:
        """Length of the window [t0, t1]: exactly ``self.window`` for a regular window (t1 - t0
        carries the round-off of the window times, which would make the participants' step
        sizes, and a structure's cached factorisation, depend on the window index and so on
        where a run was restarted), else t1 - t0 (a final, shorter window)."""
        T = t1 - t0
        if abs(T - self.window) <= TIME_EPS * self.window:
            return float(self.window)
        return T

    def _measure(self, where: str, F_f1, x, x_t, s_t, force_error) -> tuple:
        """How far the iterate x is from its answer x_t: the finite check of what the
        participants returned, then (residual, r_abs) of the displacement criterion and, where
        the structure reports a fictitious force error (``force_error``, else None), its triple
        ``got``, its scale (N) and its ratio to the load (nan without one)."""
        check_finite(
            where,
            **{"fluid forces": F_f1, "structure displacement": x_t, "structure velocity": s_t},
        )
        residual, r_abs = self.criterion.measure(x, x_t, self.d)
        got = force_error() if force_error is not None else None
        f_scale = 0.0 if got is None else got[1]
        f_ratio = (
            float("nan")
            if got is None
            else self.force_criterion.measure(*got, peak=self.force_scale_peak)
        )
        return residual, r_abs, got, f_scale, f_ratio

    def _predict(self, T: float) -> np.ndarray:
        """The window-end interface displacement of the first iterate (``coupling.predictor``):
        "velocity" d_n + T v_n (consistent for Newmark's average acceleration); "constant" d_n
        (preCICE's extrapolation order 0); "linear" d_n + T (d_n - d_n-1) / T_n-1 (order 1;
        d_n at the first window)."""
        kind = self.config.predictor
        if kind == "velocity":
            return self.d + T * self.v
        if kind == "linear" and math.isfinite(self.T_prev):
            return self.d + (T / self.T_prev) * (self.d - self.d_prev)
        return self.d.copy()

    def _evaluate(self, t0, t1, d_f0, v_f0, x, s, set_iterate, timings) -> tuple:
        """One iteration of both participants from the window's start: the fluid over [t0, t1]
        given the interface iterate (x, s) at t1, its forces mapped, the structure under them.
        Returns (d_f1, F_f1, n_f, F_s1, x_t, s_t, n_s): the iterate on the fluid's points, the
        fluid's window force and sub-steps, the force on the structure, the structure's answer
        (displacement, velocity) and its sub-steps. ``timings`` is added to."""
        T = self.window_length(t0, t1)
        tic = time.perf_counter()
        d_f1 = self.mapping.displacement_to_fluid(x)
        if self.config.interface_velocity == "displacement_rate":
            # the points' own velocity: they move linearly from H d_n to H x over the window
            v_f0 = v_f1 = (d_f1 - d_f0) / T
        else:
            v_f1 = self.mapping.velocity_to_fluid(s, x)
        timings["mapping"] += time.perf_counter() - tic
        tic = time.perf_counter()
        try:
            F_f1, n_f = self._fluid_window(t0, t1, d_f0, v_f0, d_f1, v_f1)
        finally:
            timings["fluid"] += time.perf_counter() - tic
        tic = time.perf_counter()
        # the fluid saw the structure at x
        F_s1 = self.mapping.forces_to_structure(F_f1, x)
        timings["mapping"] += time.perf_counter() - tic
        tic = time.perf_counter()
        if set_iterate is not None:  # the x the fluid saw (fictitious mass)
            set_iterate(x, T)
        try:
            x_t, s_t, n_s = self._structure_window(t0, t1, F_s1)
        finally:
            timings["structure"] += time.perf_counter() - tic
        return d_f1, F_f1, n_f, F_s1, x_t, s_t, n_s

    def _fluid_window(self, t0, t1, d0, v0, d1, v1) -> tuple[np.ndarray, int]:
        """Sub-cycle the fluid over [t0, t1] (in local time 0 .. T, T = window_length); returns
        (window force, sub-steps)."""
        T = self.window_length(t0, t1)
        fluid = self.fluid
        acc = {"F": None}
        mean = self.config.force_sampling == "mean"

        def before(t_next: float, dt: float) -> None:
            theta = t_next / T
            fluid.write(DISPLACEMENT, interpolate(d0, d1, theta))
            fluid.write(VELOCITY, interpolate(v0, v1, theta))

        def after(t_now: float, dt: float) -> None:
            F = self._read_forces()
            if not mean:
                acc["F"] = F
            elif acc["F"] is None:
                acc["F"] = dt * F
            else:
                acc["F"] += dt * F

        n = subcycle(fluid.advance, fluid.max_dt, 0.0, T, before, after, who="fluid")
        F = acc["F"] / T if mean else acc["F"]
        return F, n

    def _structure_window(self, t0, t1, F1) -> tuple[np.ndarray, np.ndarray, int]:
        """Sub-cycle the structure over [t0, t1] (in local time 0 .. T, T = window_length) under
        forces ramping from the previous window's value to ``F1``; returns (displacement,
        velocity, sub-steps) at t1."""
        T = self.window_length(t0, t1)
        st = self.structure
        F0 = self.F_s

        def before(t_next: float, dt: float) -> None:
            st.write(FORCES, interpolate(F0, F1, t_next / T))

        n = subcycle(st.advance, st.max_dt, 0.0, T, before, who="structure")
        d, v = read_outputs(st, (DISPLACEMENT, VELOCITY))
        return d, v, n

    def _warn(self, msg: str) -> None:
        if self.log is not None:
            self.log(msg)
        else:
            warnings.warn(msg, CouplingWarning, stacklevel=3)

    # ------------------------------------------------------------------ results / restart
    def history_arrays(self) -> dict[str, np.ndarray]:
        """Per-window columns for ``/coupling/`` of the results file (see CouplingHistory)."""
        return self.history.as_arrays(self.energy0)

    def state_dict(self) -> dict[str, Any]:
        """The scheme's state at a window end (for a checkpoint; arrays and numbers)."""
        acc = self.acceleration.state_dict() if self.acceleration is not None else {}
        return {
            "t": self.t,
            "t0": self.t0,
            "index": self.index,
            "window": self.window,
            "energy0": self.energy0,
            "d": self.d.copy(),
            "v": self.v.copy(),
            "F_s": self.F_s.copy(),
            "F_f": self.F_f.copy(),
            "d_f": self.d_f.copy(),
            "d_prev": self.d_prev.copy(),
            "T_prev": self.T_prev,
            "force_scale_peak": self.force_scale_peak,
            **{f"acceleration/{k}": v for k, v in acc.items()},
        }

    def load_state_dict(self, state: dict[str, Any]) -> None:
        """Continue from :meth:`state_dict` (after :meth:`initialize` with restored participants)."""
        self.t, self.t0 = float(state["t"]), float(state["t0"])
        self.index = int(state["index"])
        self.window = float(state["window"])
        self.energy0 = float(state["energy0"])
        self.d, self.v = np.array(state["d"]), np.array(state["v"])
        self.F_s, self.F_f = np.array(state["F_s"]), np.array(state["F_f"])
        # checkpoints written before d_f was kept: the structure's displacement, mapped
        self.d_f = (
            np.array(state["d_f"]) if "d_f" in state else self.mapping.displacement_to_fluid(self.d)
        )
        # checkpoints written before the linear predictor: its first window predicts d_n
        self.d_prev = np.array(state["d_prev"]) if "d_prev" in state else self.d.copy()
        self.T_prev = float(state.get("T_prev", math.nan))
        # checkpoints written before the force-error criterion: no peak yet
        self.force_scale_peak = float(state.get("force_scale_peak", 0.0))
        acc = {k[13:]: v for k, v in state.items() if k.startswith("acceleration/")}
        if self.acceleration is not None:
            self.acceleration.load_state_dict(acc)
        self.detector.reset()


def read_outputs(participant, names) -> list[np.ndarray]:
    """Copies of several outputs (one round trip for a remote participant with ``read_many``)."""
    many = getattr(participant, "read_many", None)
    if many is not None:
        got = many(names)
        return [np.array(got[n], dtype=np.float64) for n in names]
    return [np.array(participant.read(n), dtype=np.float64) for n in names]


class ExplicitScheme(CouplingScheme):
    """Serial-staggered: one fluid and one structure solve per window (thesis's weak coupling)."""

    kind = "explicit"
    implicit = False


class ImplicitScheme(CouplingScheme):
    """Serial implicit: iterate each window to convergence with acceleration."""

    kind = "implicit"
    implicit = True


def create_scheme(fluid, structure, config: CouplingSection | None = None, **kw) -> CouplingScheme:
    """The scheme named by ``config.scheme`` (default config: implicit)."""
    config = config if config is not None else CouplingSection()
    return SCHEMES.create(config.scheme, fluid, structure, config, **kw)
