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

The flags are the detector's ``free_surface`` array after the dry marks of the boundary (one
int8 per particle and step; the particle count is fixed for a run). Buffers are kept across
windows; a window with more steps than any before it adds one. A step beyond the recorded ones
(not expected: the sub-steps of a window are fixed at its start) records instead of replaying.
"""

from __future__ import annotations

import numpy as np

__all__ = ["SurfaceFreeze"]


class SurfaceFreeze:
    """Records the flags of each step of a window's first iteration and replays them after a
    restore. Inactive (a no-op) until the first :meth:`start`."""

    def __init__(self) -> None:
        self._buffers: list[np.ndarray] = []
        self._recorded = 0  # steps recorded in this window
        self._next = 0  # the next step's index in this window
        self._replay = False
        self.active = False
        #: flags changed by a replay, summed over the run (how often freezing mattered)
        self.overridden = 0

    def start(self) -> None:
        """A new window: its first iteration records."""
        self.active = True
        self._recorded = 0
        self._next = 0
        self._replay = False

    def rewind(self) -> None:
        """The window restarts from its checkpoint: the next steps replay."""
        if not self.active:
            return
        self._next = 0
        self._replay = True

    def apply(self, flags: np.ndarray) -> None:
        """Record ``flags`` (int8, one per particle) for this step, or overwrite them with the
        recorded ones."""
        if not self.active:
            return
        k = self._next
        self._next += 1
        if self._replay and k < self._recorded:
            buf = self._buffers[k]
            self.overridden += int(np.count_nonzero(buf != flags))
            flags[:] = buf
            return
        if k == len(self._buffers):
            self._buffers.append(np.empty_like(flags))
        self._buffers[k][:] = flags
        self._recorded = max(self._recorded, k + 1)
