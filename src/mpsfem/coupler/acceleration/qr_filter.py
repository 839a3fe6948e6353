"""QR decomposition of the quasi-Newton difference matrix V with preCICE's QR1 / QR2 filters.

Near-dependent columns of V make the least-squares problem min |V alpha + r| ill-conditioned;
the filter finds them so that the caller drops them (from V and W alike). Householder QR
(LAPACK), recomputed after each dropped column: with the columns ordered newest first, |R_jj| is
the norm of column j orthogonal to the newer ones.

* "QR2": column j is dependent when |R_jj| < limit |v_j| (its orthogonal part is a small share of
  itself; Haelterman et al. 2016, preCICE's QR2 filter);
* "QR1": when |R_jj| < limit |R|_F (small against the whole system; preCICE's QR1 filter);
* "none": only exactly dependent (R_jj = 0) or zero columns.
"""

from __future__ import annotations

from typing import Literal

import numpy as np

FilterKind = Literal["QR1", "QR2", "none"]

#: default threshold of each filter (preCICE's defaults for QR1 and QR2)
DEFAULT_LIMIT: dict[str, float] = {"QR1": 1e-6, "QR2": 1e-2, "none": 0.0}


def filtered_qr(
    V: np.ndarray, kind: FilterKind, limit: float
) -> tuple[np.ndarray | None, np.ndarray, list[int]]:
    """QR of the columns of ``V`` (n x m, newest first) that pass the filter.

    Returns (Q (n x k) or None when no column is left, R (k x k), kept column indices in V).
    The first failing column is removed and the QR recomputed until none fails. ``V`` is the
    matrix as the least squares sees it (already scaled by the preconditioner)."""
    kept = list(range(V.shape[1]))
    while kept:
        Vm = V[:, kept]
        Q, R = np.linalg.qr(Vm, mode="reduced")
        diag = np.abs(np.diag(R))
        norms = np.linalg.norm(Vm, axis=0)
        if kind == "QR2":
            bad = diag < limit * norms
        elif kind == "QR1":
            bad = diag < limit * np.linalg.norm(R)
        else:
            bad = diag == 0.0
        bad |= norms == 0.0
        if not bad.any():
            return Q, R, kept
        del kept[int(np.argmax(bad))]
    return None, np.zeros((0, 0)), []
