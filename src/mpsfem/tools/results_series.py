"""Time series of a results file (docs/results.md) under one shape: time (T,), values (T, C).

Series names ("targets"):

* ``<probe>``: ``/probes/<probe>``; components from the group attribute ``components`` (a scalar
  probe has the one component ``value``); unit from the attribute ``unit``.
* ``structure/<member>``: ``/structure/<member>/displacement`` (T x nodes x dim, m) reduced to the
  translational displacement components of the node whose displacement magnitude peaks highest
  over the run, plus ``|u|max``, the largest magnitude over all nodes at each time.
* ``coupling``: every per-window series of ``/coupling`` (``iterations``, ``residual``, then the
  rest by name); ``coupling/<series>`` one of them.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import h5py
import numpy as np

from mpsfem.tools import ToolError

STRUCTURE_PREFIX = "structure/"
COUPLING = "coupling"
_DISPLACEMENT_NAMES = ("ux", "uy", "uz")


@dataclass
class Series:
    """One named time series: ``time`` (T,) in s, ``values`` (T, C) in ``units[c]``."""

    name: str
    title: str
    time: np.ndarray
    values: np.ndarray
    components: list[str]
    units: list[str]
    attrs: dict = field(default_factory=dict)

    def component(self, name: str) -> np.ndarray:
        """Values (T,) of component ``name``."""
        if name not in self.components:
            raise ToolError(
                f"{self.name} has no component {name!r}; its components are "
                f"{', '.join(self.components)}"
            )
        return self.values[:, self.components.index(name)]


def open_results(path: str | Path) -> h5py.File:
    """Open a results file read-only, with a clear error for a missing or non-HDF5 file.

    A file a run is still writing opens too: without HDF5's file lock, which the writer holds,
    the reader sees what the writer's last flush put on disk (docs/results.md, "Reading a
    running file"). SWMR would make that safe for concurrent appends, but forbids the new
    groups every snapshot adds, so the writer flushes whole blocks instead."""
    path = Path(path)
    if not path.is_file():
        raise ToolError(f"results file {str(path)!r} does not exist")
    try:
        return h5py.File(path, "r", locking=False)
    except OSError as exc:
        if "lock" in str(exc):
            raise ToolError(
                f"{path} is open for writing by another process (a run still going?): {exc}"
            ) from None
        raise ToolError(f"{path} is not an HDF5 results file ({exc})") from None


def _text(value) -> str:
    return value.decode() if isinstance(value, bytes) else str(value)


def list_targets(h5: h5py.File) -> list[str]:
    """Names of every series in the file: probes, ``structure/<member>``, ``coupling``."""
    out = sorted(h5["probes"]) if "probes" in h5 else []
    if "structure" in h5:
        out += [f"{STRUCTURE_PREFIX}{m}" for m in sorted(h5["structure"]) if _has_structure(h5, m)]
    if COUPLING in h5 and "time" in h5[COUPLING]:
        out.append(COUPLING)
    return out


def _has_structure(h5: h5py.File, member: str) -> bool:
    g = h5["structure"][member]
    return "time" in g and "displacement" in g


def _coupling_names(g: h5py.Group) -> list[str]:
    first = [n for n in ("iterations", "residual") if n in g]
    return first + sorted(n for n in g if n not in first and n != "time")


def _not_found(h5: h5py.File, name: str) -> ToolError:
    have = list_targets(h5)
    if COUPLING in have:
        have += [f"{COUPLING}/{n}" for n in _coupling_names(h5[COUPLING])]
    listing = ", ".join(have) if have else "(none: the file holds no series)"
    return ToolError(f"{h5.filename}: no series named {name!r}; available: {listing}")


def read_series(h5: h5py.File, name: str) -> Series:
    """The series ``name`` (see the module docstring for the naming)."""
    if name.startswith(STRUCTURE_PREFIX):
        member = name[len(STRUCTURE_PREFIX) :]
        if "structure" in h5 and member in h5["structure"] and _has_structure(h5, member):
            return _structure_series(h5, member)
        raise _not_found(h5, name)
    has_coupling = COUPLING in h5 and "time" in h5[COUPLING]
    if has_coupling and (name == COUPLING or name.startswith(COUPLING + "/")):
        g = h5[COUPLING]
        names = _coupling_names(g)
        if name != COUPLING:
            wanted = name[len(COUPLING) + 1 :]
            if wanted not in names:
                raise _not_found(h5, name)
            names = [wanted]
        vals = np.stack([g[n][:].astype(np.float64) for n in names], axis=1)
        return Series(name, "coupling windows", g["time"][:], vals, names, [""] * len(names))
    if "probes" not in h5 or name not in h5["probes"]:
        raise _not_found(h5, name)
    return _probe_series(h5, name)


def _probe_series(h5: h5py.File, name: str) -> Series:
    g = h5["probes"][name]
    t = g["time"][:]
    v = g["value"][:].astype(np.float64)
    comps = [_text(c) for c in g.attrs.get("components", ["value"])]
    v = v.reshape(v.shape[0], -1)
    if len(comps) != v.shape[1]:
        comps = [f"c{i}" for i in range(v.shape[1])] if v.shape[1] > 1 else ["value"]
    kind = _text(g.attrs.get("kind", ""))
    unit = _text(g.attrs.get("unit", ""))
    attrs = {k: g.attrs[k] for k in g.attrs}
    title = f"probe {name} ({kind})" if kind else f"probe {name}"
    if "position" in g.attrs:
        pos = ", ".join(f"{x:g}" for x in np.atleast_1d(g.attrs["position"]))
        title += f" at ({pos}) m"
    if "target" in g.attrs:
        title += f" on {_text(g.attrs['target'])}"
    return Series(name, title, t, v, comps, [unit] * len(comps), attrs)


def _structure_series(h5: h5py.File, member: str) -> Series:
    g = h5["structure"][member]
    t = g["time"][:]
    d = g["displacement"][:].astype(np.float64)  # (T, nodes, dim), m
    nodes = g["nodes"][:] if "nodes" in g else None
    dim = d.shape[2] if d.ndim == 3 else 1
    d = d.reshape(d.shape[0], -1, dim)
    mag = np.sqrt(np.sum(d * d, axis=2))  # (T, nodes)
    if mag.size:
        node = int(np.argmax(np.nanmax(np.nan_to_num(mag, nan=-np.inf), axis=0)))
        envelope = np.nanmax(mag, axis=1)
    else:
        node, envelope = 0, np.zeros(0)
    comps = list(_DISPLACEMENT_NAMES[:dim]) if dim <= 3 else [f"u{i}" for i in range(dim)]
    vals = np.column_stack([d[:, node, :] if mag.size else np.zeros((0, dim)), envelope])
    where = ""
    if nodes is not None and len(nodes) > node:
        where = " at (" + ", ".join(f"{x:g}" for x in np.atleast_1d(nodes[node])) + ") m"
    title = f"structure member {member}: node {node}{where} (largest displacement), |u| max"
    return Series(
        f"{STRUCTURE_PREFIX}{member}",
        title,
        t,
        vals,
        [*comps, "|u|max"],
        ["m"] * (dim + 1),
        {"node": node},
    )
