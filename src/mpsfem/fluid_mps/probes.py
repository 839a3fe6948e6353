"""Fluid-side probes: the exact definition of each kind lives in its function's docstring.

All sums run in a fixed (serial) order, so probe values are bit-reproducible.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from mpsfem.scenario.base import InvalidValue

# probe kind -> (unit in 3D, components); in 2D forces and energies are per metre of width
PROBE_UNITS = {
    "pressure": ("Pa", ()),
    "wave_gauge": ("m", ()),
    "front": ("m", ()),
    "force": ("N", ("fx", "fy", "fz")),
    "energy": ("J", ("kinetic", "potential")),
    "displacement": ("m", ("ux", "uy", "uz")),
}
PER_WIDTH_IN_2D = ("force", "energy")


def probe_unit(kind: str, dim: int) -> str:
    """Unit of a probe kind's values: a 2D force is N/m and a 2D energy J/m (per unit width)."""
    unit = PROBE_UNITS[kind][0]
    return f"{unit}/m" if dim == 2 and kind in PER_WIDTH_IN_2D else unit


@njit(cache=True)
def pressure_at(pos, p, kind, point, radius):
    """Mean pressure (Pa) of fluid (0) and pressure-wall (1, 3) particles within ``radius`` of
    ``point``; NaN when no such particle is there (the gauge is dry)."""
    r2 = radius * radius
    acc = 0.0
    cnt = 0
    dim = pos.shape[1]
    for i in range(pos.shape[0]):
        k = kind[i]
        if k != 0 and k != 1 and k != 3:
            continue
        d2 = 0.0
        for a in range(dim):
            dx = pos[i, a] - point[a]
            d2 += dx * dx
        if d2 <= r2:
            acc += p[i]
            cnt += 1
    return acc / cnt if cnt > 0 else np.nan


@njit(cache=True)
def particles_near(pos, kind, start, stop, point, radius):
    """Indices (int32) of the pressure-carrying boundary particles (WALL 1, STRUCTURE 3) of
    ``start:stop`` within ``radius`` (m) of ``point`` (m)."""
    r2 = radius * radius
    dim = pos.shape[1]
    out = np.empty(stop - start, np.int32)
    n = 0
    for i in range(start, stop):
        k = kind[i]
        if k != 1 and k != 3:
            continue
        d2 = 0.0
        for a in range(dim):
            dx = pos[i, a] - point[a]
            d2 += dx * dx
        if d2 <= r2:
            out[n] = i
            n += 1
    return out[:n]


@njit(cache=True)
def mean_pressure(p, index):
    """Mean pressure (Pa) of the particles ``index``."""
    acc = 0.0
    for c in range(index.shape[0]):
        acc += p[index[c]]
    return acc / index.shape[0]


class AttachedPressure:
    """A pressure probe that rides with a wall or structure member (``attach``).

    At set-up (the particles in their reference configuration, t = 0) it takes the
    pressure-carrying boundary particles (WALL or STRUCTURE kind, the layer whose pressure is
    the load) of the attached patches within ``radius`` of ``position``; its value at any later
    time is the mean pressure (Pa) of those same particles, which move with the wall's motion
    or with the member (rigid support motion plus elastic deflection). With ``average`` (the
    default) a sample is the mean of that pressure over the interval since the probe's previous
    sample (:class:`AttachedPressureLedger`); without it the instantaneous value.

    ``patches``: the solver's patches (``.name``, ``.start``, ``.stop``); a member ``m`` has
    the two faces ``m+`` and ``m-`` (``attach = "m"`` takes both, ``"m-"`` one face)."""

    def __init__(self, probe, patches, pos, kind, l0: float) -> None:
        self.name = probe.name
        self.average = bool(getattr(probe, "average", True))
        names = {pt.name: pt for pt in patches}
        target = probe.attach
        chosen = [names[target]] if target in names else []
        chosen += [names[f"{target}{s}"] for s in "+-" if f"{target}{s}" in names]
        if not chosen:
            faces = sorted(names) + sorted({n[:-1] for n in names if n[-1:] in "+-"})
            raise InvalidValue(
                f"probes.{probe.name}.attach",
                f"names no wall or structure member face of this run; have {faces}",
                target,
            )
        radius = probe.radius or l0
        point = np.asarray(probe.position, float)
        found = [particles_near(pos, kind, pt.start, pt.stop, point, radius) for pt in chosen]
        self.index = np.concatenate(found).astype(np.int32)
        if self.index.size == 0:
            gaps = [
                float(np.min(np.linalg.norm(pos[pt.start : pt.stop] - point, axis=1)))
                for pt in chosen
                if pt.stop > pt.start
            ]
            gap = f"; the nearest particle of it is {min(gaps):.4g} m away" if gaps else ""
            raise InvalidValue(
                f"probes.{probe.name}.position",
                f"has no pressure-layer particle of {target!r} within radius {radius:.4g} m "
                f"(the point is off the {target!r} surface in its reference configuration"
                f"{gap}); give a point on its wetted face or a larger radius",
                list(probe.position),
            )

    def value(self, p: np.ndarray) -> float:
        """Mean pressure of the attached particles, Pa."""
        return float(mean_pressure(p, self.index))

    def where(self, pos: np.ndarray) -> np.ndarray:
        """Current centroid of the attached particles, m."""
        return pos[self.index].mean(axis=0)


class AttachedPressureLedger:
    """The running pressure impulses of the attached pressure probes and their interval means.

    ``ledger[k] = (I_k, t_k, I_k(t_k))``: I_k the time integral of probe k's mean pressure since
    the start, Pa s, accumulated every step as I += dt p(t + dt) (the step's end pressure, the
    one its pressure force uses, as the force probes' ``patch_impulse``); t_k (s) and I_k(t_k) at
    its last sample (t_k = -1 before the first: checkpoints hold finite numbers only). A sample at t > t_k with ``average`` is
    (I(t) - I(t_k)) / (t - t_k) (the mean pressure over the interval, Pa), so samples integrate to
    the impulse however coarse they are; at a first sample or at t = t_k the instantaneous value.
    ``ledger`` is solver state (restored by implicit coupling, written to checkpoints)."""

    def __init__(self, probes: dict[str, AttachedPressure]) -> None:
        self.probes = list(probes.values())
        self.row = {a.name: k for k, a in enumerate(self.probes)}
        self.ledger = np.zeros((len(self.probes), 3))
        self.ledger[:, 1] = -1.0  # no sample yet

    def accumulate(self, p: np.ndarray, dt: float) -> None:
        """Add dt (s) times each probe's mean pressure of ``p`` (the state at the step's end)."""
        for k, a in enumerate(self.probes):
            self.ledger[k, 0] += dt * mean_pressure(p, a.index)  # I = sum dt_n p_n

    def impulse(self, name: str) -> float:
        """Running pressure impulse of probe ``name`` since the start of the run, Pa s."""
        return float(self.ledger[self.row[name], 0])

    def sample(self, name: str, p: np.ndarray, t: float) -> float:
        """The probe's value at time ``t`` (s), Pa: the interval mean with ``average``, else the
        instantaneous mean pressure of ``p``; marks ``t`` as the probe's last sample."""
        k = self.row[name]
        row = self.ledger[k]
        t_mark, i_mark = row[1], row[2]
        row[1], row[2] = t, row[0]
        a = self.probes[k]
        if not a.average or t_mark < 0.0 or not t > t_mark:  # first sample, or no interval
            return a.value(p)
        return float((row[0] - i_mark) / (t - t_mark))


def attach_pressure_probes(probes, patches, pos, kind, l0: float) -> dict[str, AttachedPressure]:
    """:class:`AttachedPressure` of every ``pressure`` probe with ``attach``, by probe name;
    call with the particles in their reference configuration (before a restart's state)."""
    return {
        p.name: AttachedPressure(p, patches, pos, kind, l0)
        for p in probes
        if p.kind == "pressure" and getattr(p, "attach", None)
    }


@njit(cache=True)
def surface_height(pos, kind, horizontal, half_width, up_axis, l0):
    """Free-surface height (m) at a horizontal position, ``method = "top_particle"``: the highest
    fluid particle whose
    horizontal coordinates are within ``half_width`` of ``horizontal``, plus l0/2 (a surface
    particle's centre lies half a spacing below the surface it represents). NaN when no fluid
    particle is in the column."""
    dim = pos.shape[1]
    top = -np.inf
    for i in range(pos.shape[0]):
        if kind[i] != 0:
            continue
        inside = True
        j = 0
        for a in range(dim):
            if a == up_axis:
                continue
            if abs(pos[i, a] - horizontal[j]) > half_width:
                inside = False
                break
            j += 1
        if inside and pos[i, up_axis] > top:
            top = pos[i, up_axis]
    if top == -np.inf:
        return np.nan
    return top + 0.5 * l0


@njit(cache=True, inline="always")
def _wendland_c2(r, h, dim):
    """Wendland C2 kernel (1/m^dim), support 2h, normalised to unit integral in 2D or 3D."""
    q = r / h
    if q >= 2.0:
        return 0.0
    a = 7.0 / (4.0 * np.pi * h * h) if dim == 2 else 21.0 / (16.0 * np.pi * h * h * h)
    b = 1.0 - 0.5 * q
    return a * b * b * b * b * (2.0 * q + 1.0)


@njit(cache=True)
def _fluid_fraction(cand, ncand, pos, point, up_axis, y, h, vol):
    """Kernel sum of fluid volume at ``point`` with its up coordinate set to y (1 inside)."""
    dim = pos.shape[1]
    f = 0.0
    for c in range(ncand):
        i = cand[c]
        d2 = 0.0
        j = 0
        for a in range(dim):
            if a == up_axis:
                dx = pos[i, a] - y
            else:
                dx = pos[i, a] - point[j]
                j += 1
            d2 += dx * dx
        f += vol * _wendland_c2(np.sqrt(d2), h, dim)
    return f


@njit(cache=True)
def surface_height_kernel(pos, kind, horizontal, up_axis, l0, cand):
    """Free-surface height (m) at a horizontal position: where the kernel-summed fluid fraction
    f(y) = sum_j l0^dim W(|r(y) - r_j|) falls to 1/2 along the vertical line, scanning down
    from above the highest fluid particle near the line (Wendland C2, h = 1.5 l0, support 3 l0;
    its lattice sums are 1 to +-0.5 %).

    The half-level of a half-space of lattice particles lies half a spacing above the top
    centres (exact to 1e-3 l0 at h = 1.5 l0), so still water reads its depth; unlike the highest
    particle in a narrow column, f is continuous in the particle positions, so the gauge does
    not jump by a spacing when the top particle drifts out of the column. Fluid particles only:
    keep the gauge 3 l0 from walls. NaN when the line is dry (f never reaches 1/2). ``cand`` is
    a work array (int64, >= number of particles)."""
    dim = pos.shape[1]
    h = 1.5 * l0
    support = 2.0 * h
    vol = l0**dim
    ncand = 0
    top = -np.inf
    bottom = np.inf
    for i in range(pos.shape[0]):
        if kind[i] != 0:
            continue
        d2 = 0.0
        j = 0
        for a in range(dim):
            if a == up_axis:
                continue
            dx = pos[i, a] - horizontal[j]
            d2 += dx * dx
            j += 1
        if d2 < support * support:
            cand[ncand] = i
            ncand += 1
            y = pos[i, up_axis]
            if y > top:
                top = y
            if y < bottom:
                bottom = y
    if ncand == 0:
        return np.nan
    point = horizontal
    step = 0.25 * l0
    y_hi = top + support  # f = 0 here
    y = y_hi
    while y > bottom - support:
        y_lo = y - step
        if _fluid_fraction(cand, ncand, pos, point, up_axis, y_lo, h, vol) >= 0.5:
            a, b = y_lo, y  # f(a) >= 1/2 > f(b): bisect to 1e-6 l0
            while b - a > 1e-6 * l0:
                m = 0.5 * (a + b)
                if _fluid_fraction(cand, ncand, pos, point, up_axis, m, h, vol) >= 0.5:
                    a = m
                else:
                    b = m
            return 0.5 * (a + b)
        y = y_lo
    return np.nan


@njit(cache=True)
def _find(parent, i):
    root = i
    while parent[root] != root:
        root = parent[root]
    while parent[i] != root:  # path compression
        nxt = parent[i]
        parent[i] = root
        i = nxt
    return root


@njit(cache=True)
def front_position(pos, kind, indptr, indices, link, axis, min_fraction, l0, parent, size):
    """Surge front (m): the largest coordinate along ``axis`` among fluid particles of every
    cluster holding at least ``min_fraction`` of the largest cluster's particles, plus l0/2 (the
    edge of the outermost particle's cell). Clusters are the connected components of fluid
    particles closer than ``link`` (m), so lone droplets do not count."""
    n = pos.shape[0]
    dim = pos.shape[1]
    link2 = link * link
    for i in range(n):
        parent[i] = i
        size[i] = 0
    for i in range(n):
        if kind[i] != 0:
            continue
        for q in range(indptr[i], indptr[i + 1]):
            j = indices[q]
            if j <= i or kind[j] != 0:
                continue
            d2 = 0.0
            for a in range(dim):
                dx = pos[j, a] - pos[i, a]
                d2 += dx * dx
            if d2 < link2:
                ri = _find(parent, i)
                rj = _find(parent, j)
                if ri != rj:
                    if ri < rj:
                        parent[rj] = ri
                    else:
                        parent[ri] = rj
    largest = 0
    for i in range(n):
        if kind[i] == 0:
            r = _find(parent, i)
            size[r] += 1
            if size[r] > largest:
                largest = size[r]
    front = -np.inf
    for i in range(n):
        if kind[i] == 0 and size[_find(parent, i)] >= min_fraction * largest:
            if pos[i, axis] > front:
                front = pos[i, axis]
    return front + 0.5 * l0


@njit(cache=True)
def patch_force(p, normal, start, stop, kind, area):
    """Pressure force (N; N/m in 2D) of the fluid on wall particles ``start:stop``: the sum of
    -p_i A n_i over pressure-layer particles, n_i the unit normal towards the fluid and
    A = l0^(d-1) the area a particle represents (thesis eq. 2-51, F_i = P_i l0^(d-1) n_i)."""
    out = np.zeros((1, normal.shape[1]))
    patch_forces(p, normal, np.array([start]), np.array([stop]), kind, area, out)
    return out[0]


@njit(cache=True)
def patch_forces(p, normal, starts, stops, kind, area, out):
    """out[k] = :func:`patch_force` of particles ``starts[k]:stops[k]``, into ``out`` (no
    allocation: the momentum budget takes every patch's every step)."""
    dim = normal.shape[1]
    for k in range(starts.shape[0]):
        for a in range(dim):
            out[k, a] = 0.0
        for i in range(starts[k], stops[k]):
            if kind[i] != 1 and kind[i] != 3:
                continue
            for a in range(dim):
                out[k, a] -= p[i] * area * normal[i, a]


@njit(cache=True)
def fluid_energy(pos, vel, kind, mass, gravity):
    """Kinetic sum(m v^2 / 2) and potential sum(-m g . x) energy of the fluid particles, J (J/m
    in 2D); the potential energy's zero is the origin."""
    dim = pos.shape[1]
    ek = 0.0
    ep = 0.0
    for i in range(pos.shape[0]):
        if kind[i] != 0:
            continue
        v2 = 0.0
        gx = 0.0
        for a in range(dim):
            v2 += vel[i, a] * vel[i, a]
            gx += gravity[a] * pos[i, a]
        ek += 0.5 * mass * v2
        ep -= mass * gx
    return ek, ep
