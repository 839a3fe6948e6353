"""Small participants for tests, benchmarks and demos of the coupler (no MPS, no FEM).

:class:`SpringMassStructure`
    A 2D member of length L along x at y = 0 (``n_nodes`` nodes, segment cells, geometric
    thickness t): every node carries mass m_s / n_nodes and a ground spring, neighbours are
    joined by springs; the y components move (Newmark, average acceleration), x stays put.
:class:`AddedMassFluid`
    Interface particles on both faces of a straight 2D member (spacing l0, at +-t/2 along its
    normal; any structure participant, e.g. the FEM beam). It reacts to
    the wall acceleration it is given with an added-mass force, F_i = -m_i a_i, plus a constant
    pressure load p0 on the face the member's normal points to. The added mass m_i varies along the member (profile
    1 + x / L), so the coupled fixed point has several distinct eigenvalues. With mass ratio
    mu = sum m_i / m_s, staggered (explicit) coupling is unstable for mu above about 2, plain
    fixed-point iteration diverges for mu above about 2, and the coupled (monolithic) problem is
    stable for every mu.

Both honour the participant protocol exactly (checkpoint/restore bit for bit, ``max_dt``,
copying inputs), and the fluid's ``max_dt`` is shorter than the structure's to exercise
sub-cycling.
"""

from __future__ import annotations

import numpy as np

from mpsfem.coupler.participant import InterfaceMesh, as_interface_mesh


class SpringMassStructure:
    name = "structure"

    def __init__(
        self,
        n_nodes: int = 11,
        length: float = 1.0,
        mass: float = 10.0,
        stiffness: float = 4.0e4,
        coupling_stiffness: float = 2.0e4,
        thickness: float = 0.04,
        dt: float = 1e-3,
    ) -> None:
        self.n = n_nodes
        x = np.linspace(0.0, length, n_nodes)
        self.mesh = InterfaceMesh(
            np.c_[x, np.zeros_like(x)],
            np.tile([0.0, 1.0], (n_nodes, 1)),
            {"line": np.c_[np.arange(n_nodes - 1), np.arange(1, n_nodes)]},
            thickness,
        )
        self.m = np.full(n_nodes, mass / n_nodes)
        lap = 2.0 * np.eye(n_nodes) - np.eye(n_nodes, k=1) - np.eye(n_nodes, k=-1)
        lap[0, 0] = lap[-1, -1] = 1.0
        self.K = stiffness / n_nodes * np.eye(n_nodes) + coupling_stiffness * lap
        self.dt = dt
        self.t = 0.0
        self.u = np.zeros(n_nodes)
        self.v = np.zeros(n_nodes)
        self.a = np.zeros(n_nodes)
        self.f = np.zeros(n_nodes)  # y force at the end of the next step
        self._inv: dict[float, np.ndarray] = {}
        self._ckpt = None
        self.steps = 0
        self.started = False

    def interface(self) -> InterfaceMesh:
        return self.mesh

    def write(self, name: str, array: np.ndarray) -> None:
        if name != "forces":
            raise KeyError(f"structure takes 'forces', not {name!r}")
        arr = np.asarray(array, dtype=np.float64)
        if arr.shape != (self.n, 2):
            raise ValueError(f"forces of shape {arr.shape}, expected {(self.n, 2)}")
        self.f = arr[:, 1].copy()
        if not self.started:  # the initial load (t0): initial acceleration
            self.a = (self.f - self.K @ self.u) / self.m

    def read(self, name: str) -> np.ndarray:
        vals = {"displacement": self.u, "velocity": self.v, "acceleration": self.a}
        if name not in vals:
            raise KeyError(f"structure has no {name!r}")
        out = np.zeros((self.n, 2))
        out[:, 1] = vals[name]
        return out

    def advance(self, dt: float) -> float:
        inv = self._inv.get(dt)
        if inv is None:
            inv = self._inv[dt] = np.linalg.inv(np.diag(self.m) + 0.25 * dt * dt * self.K)
        u_pred = self.u + dt * self.v + 0.25 * dt * dt * self.a
        a1 = inv @ (self.f - self.K @ u_pred)
        self.u = u_pred + 0.25 * dt * dt * a1
        self.v = self.v + 0.5 * dt * (self.a + a1)
        self.a = a1
        self.t += dt
        self.steps += 1
        self.started = True
        return dt

    def max_dt(self) -> float:
        return self.dt

    def checkpoint(self) -> None:
        self._ckpt = (
            self.t,
            self.steps,
            self.u.copy(),
            self.v.copy(),
            self.a.copy(),
            self.f.copy(),
        )

    def restore(self) -> None:
        t, n, u, v, a, f = self._ckpt
        self.t, self.steps = t, n
        self.u, self.v, self.a, self.f = u.copy(), v.copy(), a.copy(), f.copy()

    def energy(self) -> tuple[float, float]:
        return 0.5 * float(self.m @ self.v**2), 0.5 * float(self.u @ self.K @ self.u)


class AddedMassFluid:
    name = "fluid"

    def __init__(
        self,
        structure,
        mass_ratio: float = 1.0,
        spacing: float = 0.02,
        pressure: float = 1.0e3,
        dt: float = 4e-4,
        structure_mass: float | None = None,
    ) -> None:
        """Particles on both faces of ``structure``'s interface, a straight 2D member (any
        participant, or its interface mesh). ``structure_mass`` (default: the mock structure's
        ``m.sum()``) sets the scale of the added mass."""
        mesh = as_interface_mesh(getattr(structure, "interface", lambda: structure)())
        if mesh.dim != 2:
            raise ValueError("AddedMassFluid wraps 2D members")
        p0, p1 = mesh.points[0], mesh.points[-1]
        L = float(np.linalg.norm(p1 - p0))
        e = (p1 - p0) / L
        nrm_s = mesh.normals[0]
        half = 0.5 * float(mesh.thickness.max())
        s_ = np.arange(0.5 * spacing, L, spacing)
        n = s_.size
        line = p0 + s_[:, None] * e
        pts = np.vstack([line + half * nrm_s, line - half * nrm_s])
        nrm = np.vstack([np.tile(nrm_s, (n, 1)), np.tile(-nrm_s, (n, 1))])
        self.mesh = InterfaceMesh(pts, nrm)
        profile = 1.0 + np.r_[s_, s_] / L
        m_s = float(structure.m.sum()) if structure_mass is None else float(structure_mass)
        self.m = mass_ratio * m_s * profile / profile.sum()
        self.load = np.zeros_like(pts)
        self.load[:n] = -pressure * spacing * nrm_s  # pressure on the +normal face
        self.dt = dt
        self.t = 0.0
        self.d = np.zeros_like(pts)
        self.v_in = np.zeros_like(pts)  # velocity at the end of the next step
        self.v_old = np.zeros_like(pts)  # wall velocity at the current time
        self.F = self.load.copy()
        self.started = False
        self._ckpt = None

    def interface(self) -> InterfaceMesh:
        return self.mesh

    def write(self, name: str, array: np.ndarray) -> None:
        arr = np.array(array, dtype=np.float64)
        if arr.shape != self.d.shape:
            raise ValueError(f"{name} of shape {arr.shape}, expected {self.d.shape}")
        if name == "displacement":
            self.d = arr
        elif name == "velocity":
            self.v_in = arr
            if not self.started:  # initial wall velocity
                self.v_old = arr.copy()
        else:
            raise KeyError(f"fluid takes 'displacement' or 'velocity', not {name!r}")

    def read(self, name: str) -> np.ndarray:
        if name != "forces":
            raise KeyError(f"fluid has no {name!r}")
        return self.F.copy()

    def advance(self, dt: float) -> float:
        acc = (self.v_in - self.v_old) / dt
        self.F = self.load - self.m[:, None] * acc
        self.v_old = self.v_in.copy()
        self.t += dt
        self.started = True
        return dt

    def max_dt(self) -> float:
        return self.dt

    def checkpoint(self) -> None:
        self._ckpt = (self.t, self.v_old.copy(), self.F.copy(), self.d.copy(), self.v_in.copy())

    def restore(self) -> None:
        t, vo, F, d, vi = self._ckpt
        self.t, self.v_old, self.F, self.d, self.v_in = t, vo.copy(), F.copy(), d.copy(), vi.copy()


def pair(mass_ratio: float = 1.0, **structure_kw) -> tuple[AddedMassFluid, SpringMassStructure]:
    """(fluid, structure) mock participants with the given added-to-structure mass ratio."""
    s = SpringMassStructure(**structure_kw)
    return AddedMassFluid(s, mass_ratio), s


def monolithic_reference(mass_ratio: float, windows: int, window: float = 1e-3) -> np.ndarray:
    """Structure displacements (windows x n_nodes) of the monolithic solution of the same
    discrete problem, what implicit coupling converges to: Newmark (average acceleration) on the
    structure with the fluid's added-mass force taken implicitly (shape-function mapping).
    Valid for windows the structure takes in one step (``window`` <= its 1 ms): the fluid's
    sub-steps then all see the acceleration (v1 - v0) / T, so its window-mean force is the load
    - M_a (v1 - v0) / T."""
    from mpsfem.coupler.coupling_scheme import create_scheme
    from mpsfem.scenario.coupling import CouplingSection

    fluid, st = pair(mass_ratio)
    sch = create_scheme(
        fluid, st, CouplingSection.model_validate({"mapping": {"kind": "shape-function"}})
    )
    sch.initialize()
    H = sch.mapping.to_fluid_matrix.toarray()
    n = st.n
    y = 2 * np.arange(n) + 1  # y components of the structure nodes
    Hy = H[:, y]
    Ma = Hy.T @ (np.repeat(fluid.m, 2)[:, None] * Hy)
    Fy = (H.T @ fluid.load.reshape(-1))[y]
    M, K, T = np.diag(st.m), st.K, window
    u, v = np.zeros(n), np.zeros(n)
    a = np.linalg.solve(M, Fy - K @ u)
    out = []
    A = M + 0.25 * T * T * K + 0.5 * Ma
    for _ in range(windows):
        # Newmark with F1 = F - Ma (v1 - v0) / T, v1 = v0 + T (a0 + a1) / 2
        a1 = np.linalg.solve(A, Fy - K @ (u + T * v + 0.25 * T * T * a) - 0.5 * Ma @ a)
        u = u + T * v + 0.25 * T * T * (a + a1)
        v = v + 0.5 * T * (a + a1)
        a = a1
        out.append(u.copy())
    return np.array(out)


def static_deflection(mass_ratio: float = 1.0) -> np.ndarray:
    """K u = F of the mock pair (y displacements, m): the constant pressure load's static
    deflection. Undamped from rest, the exact and the monolithic (energy-conserving Newmark)
    responses stay within twice it, whatever the added mass."""
    from mpsfem.coupler.mapping import create_mapping
    from mpsfem.scenario.coupling import CouplingSection

    fluid, st = pair(mass_ratio)
    mapping = create_mapping(CouplingSection().mapping)
    mapping.build(fluid.interface(), st.interface())
    F = mapping.to_structure(fluid.load)[:, 1]
    return np.linalg.solve(st.K, F)
