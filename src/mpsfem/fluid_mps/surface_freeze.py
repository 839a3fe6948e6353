"""Free-surface and dry-wall flags frozen across the iterations of an implicit coupling window.

An implicit coupling scheme repeats a window from its checkpoint until the interface
displacement converges. Between two iterations the structure moves by a fraction of the window's
motion, yet a particle near the threshold can flip between surface and interior (thesis eqs.
2-18 to 2-20), or a structure particle between wet and dry, and such a flip moves the pressure
field by a finite amount: the fixed-point map the accelerator sees is then discontinuous and
the iterations stall at first contact. preCICE's mesh-based solvers do not meet this; a particle
method does, and the remedy here is to decide the discrete flags once per window:

* ``start()`` (at the window's checkpoint): the steps of the first iteration *record* their flags;
* ``rewind()`` (at each restore): the steps of later iterations *replay* the recorded flags of the
  same step, so every iteration solves the same discrete problem and only the continuous data
  (positions, velocities, interface motion) change.

**Which iterate decides** (``rule``, scenario key ``fluid.surface.freeze_rule``):

* ``"first_iterate"`` (the original rule): the flags of the window's first iterate (the
  predictor) are kept for every iteration, the accepted one included. At a small mass ratio the
  predictor can be far from the converged motion, and the accepted state then carries flags
  that do not belong to it: a particle pressed against the structure by the converged motion
  but recorded as a free-surface particle keeps p = 0, one recorded as interior beside a gap
  that opened gets a pressure it cannot support. This is how the elastic obstacle at mass
  ratio 0.01 (IQN-ILS) lost a particle (docs/coupler.md).
* ``"settled"`` (default): the same recording and replay, plus a consistency check at
  convergence. During a replay each step counts the flags its own detector would have set
  differently (:attr:`mismatched`); when the coupling scheme finds an iterate converged it asks
  :meth:`request_redecision`: if that iteration's own flags all agree with the replayed ones the
  window is accepted (its flags belong to it); if not, the next iteration records afresh from
  the settled iterate and the window goes on. An accepted window therefore has flags decided
  from its own iterate, or, after ``max_redecisions`` re-decisions in one window (a flag that
  flips back and forth at the converged state), the last ones recorded, counted in
  :attr:`unsettled_windows`.
  The coupling scheme also restarts its accelerator's window at a re-decision (the secant
  pairs gathered so far belong to the map with the old flags).

The flags are the detector's ``free_surface`` array after the dry marks of the boundary (one
int8 per particle and step; the particle count is fixed for a run). Buffers are kept across
windows; a window with more steps than any before it adds one. A step beyond the recorded ones
(not expected: the sub-steps of a window are fixed at its start) records instead of replaying.
"""

from __future__ import annotations

import numpy as np

__all__ = ["FREEZE_RULES", "MAX_REDECISIONS", "SurfaceFreeze"]

#: which iterate's flags an accepted window keeps (module docstring)
FREEZE_RULES = ("settled", "first_iterate")
#: re-decisions of the flags allowed in one window under the "settled" rule
MAX_REDECISIONS = 3


class SurfaceFreeze:
    """Records the flags of each step of a window's first iteration and replays them after a
    restore. Inactive (a no-op) until the first :meth:`start`."""

    def __init__(self, rule: str = "settled", max_redecisions: int = MAX_REDECISIONS) -> None:
        if rule not in FREEZE_RULES:
            raise ValueError(f"freeze rule {rule!r}: must be one of {', '.join(FREEZE_RULES)}")
        self.rule = rule
        self.max_redecisions = int(max_redecisions)
        self._buffers: list[np.ndarray] = []
        self._recorded = 0  # steps recorded in this window
        self._next = 0  # the next step's index in this window
        self._replay = False
        self._redecide = False  # the next rewind records afresh
        self.active = False
        #: flags changed by a replay, summed over the run (how often freezing mattered)
        self.overridden = 0
        #: flags the replays of the current iteration changed (0: the flags are its own)
        self.mismatched = 0
        #: re-decisions in the current window; over the run; windows accepted with flags that
        #: were not their own (the re-decision limit reached)
        self.redecisions = 0
        self.redecided_total = 0
        self.unsettled_windows = 0

    def start(self) -> None:
        """A new window: its first iteration records."""
        self.active = True
        self._recorded = 0
        self._next = 0
        self._replay = False
        self._redecide = False
        self.mismatched = 0
        self.redecisions = 0

    def rewind(self) -> None:
        """The window restarts from its checkpoint: the next steps replay (or, after
        :meth:`request_redecision`, record afresh)."""
        if not self.active:
            return
        self._next = 0
        self.mismatched = 0
        if self._redecide:
            self._redecide = False
            self._replay = False
            self._recorded = 0
        else:
            self._replay = True

    def consistent(self) -> bool:
        """Whether the last iteration's own flags were the ones it used."""
        return self.mismatched == 0

    def request_redecision(self) -> bool:
        """Called by the coupling scheme when an iterate has converged. Under the "settled" rule,
        returns True (and arranges that the next iteration records) when the iteration's own
        flags differ from the replayed ones and the window has re-decided fewer than
        ``max_redecisions`` times; False: accept the window."""
        if not self.active or self.rule != "settled" or self.mismatched == 0:
            return False
        if self.redecisions >= self.max_redecisions:
            self.unsettled_windows += 1
            return False
        self.redecisions += 1
        self.redecided_total += 1
        self._redecide = True
        return True

    def apply(self, flags: np.ndarray) -> None:
        """Record ``flags`` (int8, one per particle) for this step, or overwrite them with the
        recorded ones."""
        if not self.active:
            return
        k = self._next
        self._next += 1
        if self._replay and k < self._recorded:
            buf = self._buffers[k]
            changed = int(np.count_nonzero(buf != flags))
            self.overridden += changed
            self.mismatched += changed
            flags[:] = buf
            return
        if k == len(self._buffers):
            self._buffers.append(np.empty_like(flags))
        self._buffers[k][:] = flags
        self._recorded = max(self._recorded, k + 1)
