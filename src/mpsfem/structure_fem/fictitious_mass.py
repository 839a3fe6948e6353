"""Fictitious (artificial) added mass for strongly added-mass-dominated coupling (issue 21).

Inside the iterations of one implicit coupling window the structure solves, in iteration k,

    (M + M_f) a^k + C v^k + K u^k = F_fluid^k + M_f a^{k-1}

(the fictitious-mass scheme of Baek & Karniadakis 2012, J. Comput. Phys. 231; Yu, Baek &
Karniadakis 2013, J. Comput. Phys. 245), a^{k-1} being the structure's own acceleration at the same sub-step
in the previous iteration of the same window (first iteration: the acceleration at the start of
that sub-step). At the fixed point a^k = a^{k-1} and the original equation is recovered; the
iteration error of a mode with structural mass m_s, added mass m_a and fictitious mass m_f is
multiplied by about (m_f - m_a) / (m_s + m_f) per iteration (the fluid's force lags one iterate),
so m_f near m_a contracts at any mass ratio m_s / m_a, and any m_f > (m_a - m_s) / 2 contracts
(derivation: docs/coupler.md, "Fictitious mass").

An accepted window's structure satisfies its true equation M a + C v + K u = F up to the
force M_f (a^{k-1} - a^k) the scheme leaves (the fictitious force error). The displacement
residual does not bound it (a sluggish structure with a large M_f moves little while that force
is large), so the participant reports it for every sub-step (:class:`IterationHistory`,
:meth:`~.participant.StructureParticipant.fictitious_force_error`) and the coupler accepts a
window only when it is within ``coupling.convergence.fictitious_force_tolerance`` of the
interface load (:class:`mpsfem.coupler.convergence.ForceErrorCriterion`).

Wetted nodes only (``fictitious_mass_nodes = "wet"``, the default): the added mass M_f stands
in for is zero where no fluid touches the member, and M_f there only holds a dry node near its
previous acceleration. The set is decided once per coupling window, at the window's first
structure step (:func:`wet_nodes`: nodes whose interface load at the window's start, the
previous window's accepted load, or in the window's first iterate is nonzero, plus the nodes of
every element touching one), and kept for the window's iterations, so the fixed-point map does
not change between iterations. With ``fictitious_wet_update = "grow"`` the set also grows (never
shrinks) by the nodes each later iterate's forces wet: a window whose first iterate is dry and a
later one touches the water would otherwise iterate without M_f on the wetted nodes (cycling
between a dry and a wet iterate); being monotone, the set changes at most a finite number of
times in a window, after which the map is fixed and the iteration can settle. A node outside
the set steps exactly as without M_f.

``M_f`` here is lumped on the translational dofs of the interface nodes, along the member's
normal: node i carries m_f A_i n_i n_i^T, m_f the member's ``fictitious_mass`` (kg/m^2: per
m^2 of plate, per m of beam and m of depth in 2D), A_i its tributary length (beams: half of each
adjacent element) or area (plates: an element's area shared equally by its vertices), n_i the
unit normal. Over the free dofs M_f = T^T B T (T the nodal translation map of
:class:`~.system.StructureSystem`, B the block-diagonal nodal masses).

``fictitious_mass_model = "potential_flow"`` (beams, 2D) shapes M_f like the added mass it
stands in for: on every maximal run of consecutive carrying nodes of a member (each wetted
patch) B holds c M_a,ij n_i n_j^T, M_a the impact potential-flow added-mass operator of that
straight patch (:func:`.added_mass_potential.patch_added_mass`: fluid on one face, phi = 0 on
the free surface continuing its line, infinite depth, the fluid's density) and c the member's
``fictitious_mass`` read as a factor. Why: one mode's iteration error is multiplied by
(m_f - m_a) / (m_s + m_f) per iterate (docs/coupler.md, "Fictitious mass"), and a lumped m_f
matches the added mass of one mode only: the patch's added mass falls with the mode's
wavenumber (about rho / k), so under a lumped m_f sized for the first mode the short modes
contract by a factor near 1. With M_f = M_a every mode's factor is (about) 0.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from .added_mass_potential import patch_added_mass, patch_coordinates

__all__ = [
    "IterationHistory",
    "fictitious_mass_matrix",
    "node_runs",
    "tributary_measure",
    "wet_nodes",
]


def tributary_measure(nodes: np.ndarray, cells: np.ndarray) -> np.ndarray:
    """Length (2-node cells) or area (polygon cells) in m or m^2 each node takes of its cells,
    shared equally among a cell's vertices; (n_nodes,)."""
    nodes = np.asarray(nodes, dtype=float)
    cells = np.asarray(cells)
    out = np.zeros(nodes.shape[0])
    if cells.shape[1] == 2:
        size = np.linalg.norm(nodes[cells[:, 1]] - nodes[cells[:, 0]], axis=1)
    else:
        # polygon area in 3D: 1/2 |sum_i p_i x p_{i+1}| (the vector area)
        p = nodes[cells]
        q = np.roll(p, -1, axis=1)
        size = 0.5 * np.linalg.norm(np.cross(p, q).sum(axis=1), axis=1)
    np.add.at(out, cells.reshape(-1), np.repeat(size / cells.shape[1], cells.shape[1]))
    return out


def wet_nodes(
    loads: list[np.ndarray],
    cells: list[np.ndarray],
    n_points: int,
    margin: int | list[int] = 1,
    threshold: np.ndarray | None = None,
) -> np.ndarray:
    """Nodes (bool, (n_points,)) on which any of the nodal loads (each (n_points, dim), N) is
    nonzero (with ``threshold``, (n_points,) in N: whose magnitude exceeds it), widened
    `margin` times by the nodes of every cell (rows of global node indices) holding one of
    them; ``margin`` a list: one count per array of ``cells`` (a member's own margin)."""
    wet = np.zeros(n_points, dtype=bool)
    for f in loads:
        f = np.asarray(f)
        if threshold is None:
            wet |= np.any(f != 0.0, axis=1)
        else:
            wet |= np.linalg.norm(f, axis=1) > threshold
    margins = [int(margin)] * len(cells) if np.isscalar(margin) else [int(m) for m in margin]
    for k in range(max(margins, default=0)):
        grown = wet.copy()
        for c, m in zip(cells, margins, strict=True):
            if m > k:
                hit = wet[c].any(axis=1)
                grown[c[hit].reshape(-1)] = True
        wet = grown
    return wet


def node_runs(points: np.ndarray, carrying: np.ndarray) -> list[np.ndarray]:
    """Maximal runs (each an index array, in order along the member, >= 2 nodes) of
    consecutive carrying nodes of a straight member whose nodes are ``points`` ((n, dim), m),
    ``carrying`` (bool, (n,)). Nodes are ordered by their position along the end-to-end
    chord; a lone carrying node (no patch length) is left out."""
    p = np.asarray(points, dtype=float)
    order = np.argsort((p - p[0]) @ (p[np.argmax(np.linalg.norm(p - p[0], axis=1))] - p[0]))
    on = np.asarray(carrying, dtype=bool)[order]
    runs, start = [], None
    for k in range(on.size + 1):
        if k < on.size and on[k]:
            start = k if start is None else start
        elif start is not None:
            if k - start >= 2:
                runs.append(order[start:k])
            start = None
    return runs


def fictitious_mass_matrix(
    system,
    masses: list[float],
    nodes: np.ndarray | None = None,
    models: list[str] | None = None,
    density: float | None = None,
) -> sp.csr_matrix | None:
    """B, the nodal fictitious masses (kg; kg/m in 2D) as an (n_points dim)^2 matrix of
    m_f A_i n_i n_i^T blocks, with ``masses[k]`` (kg/m^2) on member k of `system` (a
    :class:`~.system.StructureSystem`); M_f = T^T B T over the free dofs. ``nodes`` (bool,
    (n_points,)): only these nodes carry it (default: all). None when no node carries any
    (the method off). ``models[k]`` (default all "lumped"): "potential_flow" puts
    masses[k] x the potential-flow added-mass operator of every run of carrying nodes
    (:func:`node_runs`) of member k there, c M_a,ij n_i n_j^T blocks, for a fluid of
    ``density`` (kg/m^3, needed then)."""
    if not any(m > 0 for m in masses):
        return None
    if nodes is not None and not np.asarray(nodes).any():
        return None
    dim = system.dim
    models = ["lumped"] * len(masses) if models is None else list(models)
    rows, cols, vals = [], [], []
    for mf, model, kind in zip(masses, system.models, models, strict=True):
        if mf <= 0:
            continue
        off = system.node_slices[model.name].start
        if kind == "potential_flow":
            _potential_flow_blocks(model, off, mf, nodes, density, dim, rows, cols, vals)
            continue
        weight = mf * tributary_measure(model.nodes, model.connectivity)
        nrm = np.asarray(model.normals, dtype=float)
        nrm = nrm / np.linalg.norm(nrm, axis=1)[:, None]
        idx = off + np.arange(model.n_nodes)
        if nodes is not None:
            keep = np.asarray(nodes, dtype=bool)[idx]
            idx, weight, nrm = idx[keep], weight[keep], nrm[keep]
        for a in range(dim):
            for b in range(dim):
                rows.append(idx * dim + a)
                cols.append(idx * dim + b)
                vals.append(weight * nrm[:, a] * nrm[:, b])
    nd = system.n_points * dim
    if not rows:
        return None
    B = sp.csr_matrix(
        (np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(nd, nd)
    )
    B.eliminate_zeros()
    return B


def _potential_flow_blocks(model, off, factor, nodes, density, dim, rows, cols, vals) -> None:
    """Append (rows, cols, vals) of factor M_a,ij n_i n_j^T over every run of carrying nodes
    of ``model`` (its nodes from ``off`` in the system's numbering)."""
    if density is None or not density > 0.0:
        raise ValueError(
            f"member {model.name!r}: fictitious_mass_model = 'potential_flow' needs the fluid "
            f"density (kg/m^3, > 0; fluid.density of the scenario), got {density!r}"
        )
    if dim != 2:
        raise ValueError(
            f"member {model.name!r}: fictitious_mass_model = 'potential_flow' is the 2D strip "
            f"operator; this is a {dim}D member (use 'lumped')"
        )
    carrying = (
        np.ones(model.n_nodes, dtype=bool)
        if nodes is None
        else np.asarray(nodes, dtype=bool)[off + np.arange(model.n_nodes)]
    )
    pts = np.asarray(model.nodes, dtype=float)
    nrm = np.asarray(model.normals, dtype=float)
    nrm = nrm / np.linalg.norm(nrm, axis=1)[:, None]
    for run in node_runs(pts, carrying):
        Ma = factor * patch_added_mass(patch_coordinates(pts[run]), density)
        gi = off + run
        for a in range(dim):
            for b in range(dim):
                rows.append(np.repeat(gi * dim + a, run.size))
                cols.append(np.tile(gi * dim + b, run.size))
                vals.append((Ma * np.outer(nrm[run, a], nrm[run, b])).reshape(-1))


def shift_factor(n: int, beta: float, gamma: float) -> float:
    """c_n: a window of n Newmark sub-steps of length h whose end accelerations a_1 .. a_n all
    shift by delta (a_0 fixed) ends displaced by c_n h^2 delta; c_n = beta + (n - 1)(gamma +
    1/2) + (n - 1)(n - 2)/2 (from u_j = u_{j-1} + h v_{j-1} + h^2 ((1/2 - beta) a_{j-1} +
    beta a_j), v_j = v_{j-1} + h ((1 - gamma) a_{j-1} + gamma a_j))."""
    return beta + (n - 1) * (gamma + 0.5) + 0.5 * (n - 1) * (n - 2)


class IterationHistory:
    """a^{k-1} for every sub-step of the current coupling window (free dofs, m/s^2 or
    rad/s^2), made consistent with the interface iterate the fluid was given.

    Iteration k (k >= 2) starts from the sub-step accelerations a_j^{k-1} the structure ended
    with in iteration k - 1 (kept across restores), the first from the window start's a_n held
    constant (Newmark's exact answer for it: u = d_n + T v_n + T^2/2 a_n). When the coupler
    hands the iterate x^k (interface displacement at the window end, what the fluid's forces
    answer to; :meth:`~.participant.StructureParticipant.set_iterate`) every a_j^{k-1} is
    shifted by the uniform nodal delta = (x^k - x^{k-1}_tilde) / (c_n h^2) (:func:`shift_factor`)
    that ends the window at x^k instead of at x^{k-1}_tilde (the structure's window end in
    k - 1): M_f a^{k-1} then answers to the same iterate as the fluid's forces, so the
    structure's window is a function of (forces, x^k) alone, which quasi-Newton acceleration
    needs (with the structure's own accelerations only, an accelerated x^k != x^{k-1}_tilde
    leaves M_f pulling towards a state the fluid never saw). With one sub-step per window the
    shifted a^{k-1} is exactly the acceleration Newmark's rule implies for x^k, and at a fixed
    point x^k = x^k_tilde it equals a^k.
    """

    def __init__(self, B: sp.csr_matrix, T: sp.csr_matrix, beta: float, gamma: float) -> None:
        self.B, self.T, self.TT = B, T.tocsr(), T.T.tocsr()
        self.beta, self.gamma = float(beta), float(gamma)
        self.steps0: int | None = None  # step count at the window start; None: no window yet
        self._start = None  # (u, v, a) at the window start
        self._prev: list[tuple[float, np.ndarray]] = []  # (h, a_j) of iteration k - 1
        self._prev_end: np.ndarray | None = None  # its nodal displacement at the window end
        self._cur: list[tuple[float, np.ndarray]] = []
        self._cur_end: np.ndarray | None = None
        self._iterate: tuple[np.ndarray, float] | None = None  # (x^k nodal, window length)
        self._force: np.ndarray | None = None  # T^T B delta of this iteration
        self._use_prev = False
        # fictitious force error of this iteration: per sub-step rms over the dofs M_f acts
        # on of M_f (a^k - a^{k-1}) - M_f delta, and the largest rms load there (N)
        self.errors: list[float] = []
        self.load_scale = 0.0

    def set_mass(self, B: sp.csr_matrix) -> None:
        """Replace the nodal fictitious masses B (a new wet set: between windows, or grown
        between two iterations of one; the kept accelerations cover every dof, so a^{k-1} of a
        node just added is its acceleration in the previous iteration)."""
        self.B = B

    def record_error(self, error: float, load: float) -> None:
        """The fictitious force error (N, rms) of the sub-step just taken and the rms interface
        load (N) over the same dofs at its ends."""
        self.errors.append(float(error))
        self.load_scale = max(self.load_scale, float(load))

    @property
    def active(self) -> bool:
        """Inside a coupling window (a checkpoint has been taken)."""
        return self.steps0 is not None

    def reset(self, steps: int, u: np.ndarray, v: np.ndarray, a: np.ndarray) -> None:
        """A new window starts (checkpoint) at step count `steps` in the state (u, v, a)."""
        self.steps0 = int(steps)
        self._start = (u.copy(), v.copy(), a.copy())
        self._prev, self._prev_end = [], None
        self._cur, self._cur_end = [], None
        self._iterate = None
        self._force = None
        self.errors, self.load_scale = [], 0.0

    def new_iteration(self) -> None:
        """The window restarts (restore): the iteration just made becomes k - 1."""
        if self._cur:
            self._prev, self._prev_end = self._cur, self._cur_end
        self._cur, self._cur_end = [], None
        self._iterate = None
        self._force = None
        self.errors, self.load_scale = [], 0.0

    def set_iterate(self, x: np.ndarray, window: float) -> None:
        """x^k: elastic nodal interface displacement (n_points * dim,) at the window end."""
        self._iterate = (np.array(x, dtype=float).reshape(-1), float(window))

    def _plan(self, h: float) -> tuple[np.ndarray | None, bool]:
        """(T^T B delta or None without an iterate, whether iteration k - 1's accelerations
        serve) for the iteration starting now with sub-steps of length h."""
        if self._iterate is None:
            return None, bool(self._prev)
        x, T = self._iterate
        n = max(1, int(np.ceil(T / h - 1e-9)))
        use = len(self._prev) == n and all(abs(hp - h) <= 1e-9 * h for hp, _ in self._prev)
        if use:
            end = self._prev_end
        else:  # a_n held over the window
            u, v, a = self._start
            end = self.T @ (u + T * v + 0.5 * T * T * a)
        delta = (x - end) / (shift_factor(n, self.beta, self.gamma) * h * h)
        return self.TT @ (self.B @ delta), use

    def previous(self, steps: int, h: float) -> tuple[np.ndarray, np.ndarray | None]:
        """(a_j^{k-1} over the free dofs, extra load T^T B delta or None) for the sub-step that
        starts at step count `steps` with length h."""
        j = steps - self.steps0
        if j == 0:
            self._force, self._use_prev = self._plan(h)
        if self._use_prev and j < len(self._prev) and abs(self._prev[j][0] - h) <= 1e-9 * h:
            return self._prev[j][1], self._force
        return self._start[2], self._force

    def store(self, h: float, u: np.ndarray, a: np.ndarray) -> None:
        """Keep the (u, a) the sub-step just taken ended with."""
        self._cur.append((float(h), a))
        self._cur_end = self.T @ u
