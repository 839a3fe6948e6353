"""MPS weight (kernel) functions, selectable by name.

Both kernels vanish for ``r >= re``:

- ``"improved"`` (thesis eq. 2-4, Zhang et al.): ``w = re / (0.85 r + 0.15 re) - 1``, finite at r =
  0 (``w(0) = 1/0.15 - 1``).
- ``"original"`` (Koshizuka & Oka): ``w = re / r - 1``. It diverges at r = 0; ``r`` is floored at
  ``1e-6 re`` so that coincident particles give a large but finite weight instead of ``inf``.

Numba kernels take the integer code (``weight_code(name)``) and call :func:`weight`.
"""

from __future__ import annotations

from numba import njit

IMPROVED = 0
ORIGINAL = 1

WEIGHTS: dict[str, int] = {"improved": IMPROVED, "original": ORIGINAL}


def weight_code(name) -> int:
    """Integer code of a weight function given by name (an int code is passed through)."""
    if isinstance(name, int) and not isinstance(name, bool):
        if name in WEIGHTS.values():
            return name
        allowed = sorted(WEIGHTS.values())
        raise ValueError(f"unknown weight function code {name!r}; allowed: {allowed}")
    try:
        return WEIGHTS[name]
    except (KeyError, TypeError):
        raise ValueError(
            f"unknown weight function {name!r}; allowed: {', '.join(sorted(WEIGHTS))}"
        ) from None


@njit(cache=True, inline="always")
def weight(r, re, code):
    """Weight w(r) for kernel radius ``re`` and kernel ``code`` (0 improved, 1 original)."""
    if r >= re:
        return 0.0
    if code == 0:
        return re / (0.85 * r + 0.15 * re) - 1.0
    rr = r if r > 1e-6 * re else 1e-6 * re
    return re / rr - 1.0


def weight_py(r, re, name="improved"):
    """Vectorised NumPy version of :func:`weight` (tests, plotting, lattice constants)."""
    import numpy as np

    code = weight_code(name)
    r = np.asarray(r, dtype=np.float64)
    if code == IMPROVED:
        w = re / (0.85 * r + 0.15 * re) - 1.0
    else:
        w = re / np.maximum(r, 1e-6 * re) - 1.0
    return np.where(r < re, w, 0.0)
