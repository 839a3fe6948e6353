"""Exceptions of the coupler. Every message says what happened, where and what to change."""

from __future__ import annotations


class CouplingError(RuntimeError):
    """Base class of coupling failures (a run stops on it after flushing its results)."""


class CouplingNotConvergedError(CouplingError):
    """An implicit coupling window reached ``max_iterations`` above the tolerance."""


class CouplingDivergedError(CouplingError):
    """Coupling iterations or explicit windows blow up (non-finite values, unbounded growth)."""


class PeerLostError(CouplingError):
    """The other participant died or went silent for longer than ``timeout_s``."""


class PeerError(CouplingError):
    """The other participant raised an exception; its type and message are in this message."""


class CouplingWarning(UserWarning):
    """A window accepted without convergence (``on_divergence = "continue"``)."""
