"""Acceleration of the implicit coupling fixed point, as in preCICE.

The coupling iteration of one window is a fixed point x = S(F(x)): the first participant (fluid)
is driven by x, the interface displacement at the window end on the structure's nodes; the second
participant (structure) answers x_tilde = S(F(x)). An accelerator proposes the next x from the
history of (x, x_tilde). It acts on the *second participant's* values on its own mesh (before
mapping), the displacement being the primary data whose residual r = x_tilde - x drives it.
Secondary data (the velocity) is updated with the same linear combination, so (displacement,
velocity) pairs that Newmark makes consistent stay consistent.

Vectors are flat float64 arrays (the (n, dim) arrays raveled).
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Mapping
from typing import Any, ClassVar

import numpy as np

from mpsfem.scenario.base import Section

Secondary = Mapping[str, tuple[np.ndarray, np.ndarray]]


class Acceleration(ABC):
    """Base class: :meth:`compute` once per iteration but the last, :meth:`start_window` /
    :meth:`iterations_converged`, :meth:`end_window` around every window."""

    kind: ClassVar[str]
    Params: ClassVar[type[Section]]

    def __init__(self, params: Section | None = None) -> None:
        self.params = params if params is not None else self.Params()
        self.iteration = 0

    def start_window(self) -> None:
        """A new window begins (its first iteration follows)."""
        self.iteration = 0

    def restart_window(self) -> None:
        """The window's fixed-point map changed discretely (its fluid re-decided its frozen
        flags): forget what this window's iterations taught, start as at the window's start."""
        self.start_window()

    def compute(
        self, x: np.ndarray, x_tilde: np.ndarray, secondary: Secondary | None = None
    ) -> tuple[np.ndarray, dict[str, np.ndarray]]:
        """Next iterate from the values used (``x``) and the answer (``x_tilde``).

        ``secondary`` maps a name to (values used, answer); returns (x_next, secondary_next).
        """
        x = np.asarray(x, dtype=np.float64)
        x_tilde = np.asarray(x_tilde, dtype=np.float64)
        out = self._compute(x, x_tilde, dict(secondary or {}))
        self.iteration += 1
        return out

    @abstractmethod
    def _compute(
        self, x: np.ndarray, x_tilde: np.ndarray, secondary: dict
    ) -> tuple[np.ndarray, dict[str, np.ndarray]]: ...

    def iterations_converged(  # noqa: B027 - optional hook
        self, x: np.ndarray, x_tilde: np.ndarray, secondary: Secondary | None = None
    ) -> None:
        """The window's iterations end with (``x``, ``x_tilde``), the accepted iterate and its
        answer (converged or continued), which :meth:`compute` never saw; called before
        :meth:`end_window` (preCICE's ``iterationsConverged``). Default: nothing to learn."""

    def end_window(self) -> None:  # noqa: B027 - optional hook
        """The window was accepted (converged or continued)."""

    def state_dict(self) -> dict[str, Any]:
        """State needed to continue bit for bit after a restart."""
        return {}

    def load_state_dict(self, state: dict[str, Any]) -> None:  # noqa: B027 - optional hook
        """Inverse of :meth:`state_dict`."""


def relax(
    omega: float, x: np.ndarray, x_tilde: np.ndarray, secondary: dict
) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """x + omega (x_tilde - x), the same for every secondary pair."""
    out = x + omega * (x_tilde - x)
    sec = {k: s + omega * (st - s) for k, (s, st) in secondary.items()}
    return out, sec
