"""HDF5 results file of the design-brief contract, written incrementally.

Layout (SI units; in 2D forces are per unit width):

- root attributes: ``scenario`` (TOML text as given), ``overrides`` (the ``--set`` list),
  ``scenario_resolved`` (JSON of the validated scenario), ``version``, ``wall_time`` (s, updated
  at every flush), ``status`` ("running", "finished" or "failed: <reason>"), and after a restart
  ``restarts`` (JSON list of {checkpoint, time, overrides}, one per restart).
- ``/probes/<name>/time`` (T,) and ``/probes/<name>/value`` (T, ...); group attributes ``kind``,
  ``unit``, ``components`` (names of the trailing axis) and ``position`` where the probe has one.
- ``/particles/<k>`` snapshots (``k`` zero-padded) with ``pos``, ``vel`` (N x dim), ``p``,
  ``kind`` and attribute ``time``.
- ``/structure/<name>/time``, ``/structure/<name>/displacement`` (T x nodes x dim) and
  ``/structure/<name>/nodes``.
- ``/coupling/{time,iterations,residual}`` per coupling window.

Time series are resizable chunked datasets. Probe and structure samples are buffered in memory
(one HDF5 append per sample costs about a millisecond) and written in blocks by
:meth:`ResultsFile.flush`, which the run loop calls on a wall-clock cadence, so a run killed midway
leaves a readable file holding everything up to the last flush. The XDMF sidecar, when asked
for, is rewritten by that flush, after the file is on disk (and after a restart's truncation), so
it never lists a snapshot the file does not hold. Only one process writes the file (the fluid
participant in coupled runs).
"""

from __future__ import annotations

import json
import time
from collections.abc import Sequence
from pathlib import Path

import h5py
import numpy as np

from mpsfem import __version__
from mpsfem.results import disk_space
from mpsfem.results.xdmf import write_xdmf

SNAPSHOT_DIGITS = 6
#: /momentum_budget datasets of the fluid as a whole and per boundary patch (momentum_budget.py)
BUDGET_FLUID_KEYS = (
    "fluid_momentum",
    "momentum_change",
    "gravity",
    "sponge",
    "viscous",
    "collision",
    "pressure",
    "internal_pressure",
    "internal_viscous",
    "internal_collision",
    "residual",
    "residual_external",
)
BUDGET_PATCH_KEYS = ("pressure", "viscous", "collision", "exchange", "reported")


def _append_rows(ds: h5py.Dataset, rows: np.ndarray) -> None:
    """Append ``rows`` along axis 0 of a resizable dataset."""
    n = ds.shape[0]
    ds.resize(n + rows.shape[0], axis=0)
    ds[n:] = rows


def _rows_up_to(times: np.ndarray, t: float) -> int:
    """How many leading rows a restart at ``t`` keeps: those with time <= t, up to the first
    that is not later than its predecessor (a row a killed append left unwritten reads time 0:
    searching a series that is no longer sorted kept it, and everything after it)."""
    n = len(times)
    if n == 0:
        return 0
    bad = np.flatnonzero(np.diff(times) <= 0.0)
    ordered = int(bad[0]) + 1 if len(bad) else n
    return int(np.searchsorted(times[:ordered], t, side="right"))


def _series(group: h5py.Group, name: str, tail: tuple[int, ...], dtype=np.float64) -> h5py.Dataset:
    """Create an empty resizable time series with trailing shape ``tail``."""
    chunk_rows = max(1, min(1024, (1 << 16) // max(1, int(np.prod(tail, dtype=np.int64)) * 8)))
    return group.create_dataset(
        name, shape=(0, *tail), maxshape=(None, *tail), chunks=(chunk_rows, *tail), dtype=dtype
    )


class ResultsFile:
    """Writer of the results-file contract; create with :meth:`create` or :meth:`open_append`."""

    def __init__(self, h5: h5py.File, xdmf: str | Path | None = None) -> None:
        self._h5 = h5
        self._t_start = time.perf_counter()
        self._wall_offset = float(h5.attrs.get("wall_time", 0.0))
        self._n_snapshots = len(h5["particles"]) if "particles" in h5 else 0
        self._pending: dict[str, tuple[list[float], list[np.ndarray]]] = {}
        self._budget_rows: list[tuple[float, dict[str, np.ndarray]]] = []
        self._coupling_rows: list[tuple[float, int, float, dict[str, float]]] = []
        self._xdmf = Path(xdmf) if xdmf is not None else None
        self._xdmf_snapshots = -1  # snapshots the sidecar lists (-1: not written yet)

    # ------------------------------------------------------------------ creation
    @classmethod
    def create(
        cls,
        path: str | Path,
        scenario_text: str,
        overrides: Sequence[str] = (),
        scenario_resolved: dict | None = None,
        xdmf: str | Path | None = None,
    ) -> ResultsFile:
        """Create (truncate) ``path`` and write the root attributes; ``xdmf``: path of the
        sidecar to keep in step with the snapshots on disk (None: no sidecar)."""
        h5 = h5py.File(path, "w")
        h5.attrs["scenario"] = scenario_text
        h5.attrs["overrides"] = json.dumps(list(overrides))
        h5.attrs["scenario_resolved"] = json.dumps(scenario_resolved or {})
        h5.attrs["version"] = __version__
        h5.attrs["wall_time"] = 0.0
        h5.attrs["status"] = "running"
        for g in ("probes", "particles", "structure"):
            h5.require_group(g)
        out = cls(h5, xdmf)
        out.flush()
        return out

    @classmethod
    def open_append(
        cls,
        path: str | Path,
        truncate_after: float | None = None,
        xdmf: str | Path | None = None,
    ) -> ResultsFile:
        """Reopen an existing file to continue a run (restart).

        Rows and snapshots with time > ``truncate_after`` are removed first, so a restarted run
        continues the series exactly where its checkpoint was taken; the sidecar ``xdmf`` is
        rewritten to match.
        """
        path = Path(path)
        if not path.is_file():
            raise ValueError(f"results file {str(path)!r} does not exist: nothing to continue")
        try:
            h5 = h5py.File(path, "r+")  # never creates: a restart continues an existing file
        except OSError as exc:
            raise ValueError(f"{path}: not a readable HDF5 results file ({exc})") from None
        missing = [g for g in ("probes", "particles", "structure") if g not in h5]
        if missing:
            h5.close()
            raise ValueError(
                f"{path}: not a results file of mpsfem (no group {', '.join(missing)})"
            )
        h5.attrs["status"] = "running"
        out = cls(h5, xdmf)
        if truncate_after is not None:
            out._truncate_after(truncate_after)
        out.flush()
        return out

    def mark_end_samples(self, t: float, paths: Sequence[str]) -> None:
        """Record that the samples at ``paths`` (probe/structure groups, snapshot groups) were
        taken at ``t`` (s) only because the run ended there, off their grid: a restart from
        that time removes them, so that it continues the series as an uninterrupted run has
        them (root attribute ``end_samples``)."""
        self._h5.attrs["end_samples"] = json.dumps({"time": float(t), "paths": list(paths)})

    def _drop_end_samples(self, t: float) -> None:
        """Remove the samples :meth:`mark_end_samples` recorded, if the run continues from
        their time ``t`` (s)."""
        raw = self._h5.attrs.get("end_samples")
        if raw is None:
            return
        del self._h5.attrs["end_samples"]
        end = json.loads(raw)
        if end["time"] != t:
            return
        for path in end["paths"]:
            if path not in self._h5:
                continue
            g = self._h5[path]
            if path.startswith("particles/"):
                del self._h5[path]
                continue
            if g["time"].shape[0] and g["time"][-1] == t:
                for ds in g.values():
                    if not ds.name.endswith("/nodes"):
                        ds.resize(ds.shape[0] - 1, axis=0)

    def _truncate_after(self, t: float) -> None:
        self._flush_series()
        self._drop_end_samples(t)
        for top in ("probes", "structure"):
            for g in self._h5[top].values():
                if "time" not in g:
                    continue
                keep = _rows_up_to(g["time"][:], t)
                for ds in g.values():
                    if ds.name.endswith("/nodes"):
                        continue
                    ds.resize(keep, axis=0)
        for top in ("coupling", "momentum_budget"):
            if top not in self._h5:
                continue
            g = self._h5[top]
            keep = _rows_up_to(g["time"][:], t)
            for ds in g.values():
                ds.resize(keep, axis=0)
        for key in list(self._h5["particles"].keys()):
            attrs = self._h5["particles"][key].attrs
            if attrs["time"] > t or "failure" in attrs:  # a failed step's state goes too
                del self._h5["particles"][key]
        self._n_snapshots = len(self._h5["particles"])

    def record_restart(self, checkpoint: str | Path, t: float, overrides: Sequence[str]) -> None:
        """Append a restart (checkpoint path, time s, its ``--set`` list) to the root attribute
        ``restarts`` (JSON list); ``overrides`` keeps the first run's list."""
        restarts = json.loads(self._h5.attrs.get("restarts", "[]"))
        restarts.append(
            {"checkpoint": str(checkpoint), "time": float(t), "overrides": list(overrides)}
        )
        self._h5.attrs["restarts"] = json.dumps(restarts)

    # ------------------------------------------------------------------ probes
    def add_probe(
        self,
        name: str,
        kind: str,
        unit: str,
        components: Sequence[str] = (),
        position: Sequence[float] | None = None,
        attrs: dict | None = None,
    ) -> None:
        """Declare probe ``name`` (idempotent for restarts: an existing probe is kept)."""
        probes = self._h5["probes"]
        if name in probes:
            return
        g = probes.create_group(name)
        g.attrs["kind"] = kind
        g.attrs["unit"] = unit
        g.attrs["components"] = list(components) if components else ["value"]
        if position is not None:
            g.attrs["position"] = np.asarray(position, dtype=np.float64)
        for key, val in (attrs or {}).items():
            g.attrs[key] = val
        _series(g, "time", ())
        _series(g, "value", (len(components),) if components else ())

    def append_probe(self, name: str, t: float, value: float | np.ndarray) -> None:
        """Append one sample of probe ``name`` at time ``t`` (s); buffered until the next flush."""
        self._buffer(f"probes/{name}", "value", t, value)

    def append_probe_rows(self, name: str, times: np.ndarray, values: np.ndarray) -> None:
        """Append many samples of probe ``name`` at once (first axis time)."""
        self._flush_series(f"probes/{name}")
        g = self._h5["probes"][name]
        tail = g["value"].shape[1:]
        _append_rows(g["time"], np.asarray(times, dtype=np.float64).reshape(-1))
        _append_rows(g["value"], np.asarray(values, dtype=np.float64).reshape(-1, *tail))

    def _buffer(self, group: str, dataset: str, t: float, value) -> None:
        key = f"{group}/{dataset}"
        if key not in self._pending:
            if group not in self._h5:
                raise KeyError(f"{group} was not declared")
            self._pending[key] = ([], [])
        times, values = self._pending[key]
        times.append(float(t))
        values.append(np.array(value, dtype=np.float64))

    def _flush_series(self, group: str | None = None) -> None:
        for key in list(self._pending):
            grp, _, dataset = key.rpartition("/")
            if group is not None and grp != group:
                continue
            times, values = self._pending.pop(key)
            if not times:
                continue
            g = self._h5[grp]
            tail = g[dataset].shape[1:]
            _append_rows(g["time"], np.asarray(times))
            _append_rows(g[dataset], np.stack(values).reshape(len(times), *tail))

    # ------------------------------------------------------------------ particles
    def write_snapshot(
        self,
        t: float,
        pos: np.ndarray,
        vel: np.ndarray,
        p: np.ndarray,
        kind: np.ndarray,
        failure: str | None = None,
    ) -> str:
        """Write particle snapshot ``/particles/<k>`` at time ``t`` (s); returns its key.

        ``failure``: the state a failed step left (partly updated, so ``t`` is only the time the
        step started from or reached), with the reason as attribute ``failure``. It is for
        diagnosis: the XDMF sidecar leaves it out and a restart deletes it."""
        key = f"{self._n_snapshots:0{SNAPSHOT_DIGITS}d}"
        size = pos.nbytes + vel.nbytes + p.nbytes + kind.nbytes
        disk_space.require(self.path, size, f"snapshot {key} of the results file")
        g = self._h5["particles"].create_group(key)
        g.attrs["time"] = float(t)
        if failure is not None:
            g.attrs["failure"] = str(failure)
        g.create_dataset("pos", data=pos)
        g.create_dataset("vel", data=vel)
        g.create_dataset("p", data=p)
        g.create_dataset("kind", data=kind)
        self._n_snapshots += 1
        return key

    @property
    def n_snapshots(self) -> int:
        return self._n_snapshots

    # ------------------------------------------------------------------ structure
    def add_structure(self, name: str, nodes: np.ndarray) -> None:
        """Declare structure member ``name`` with reference node coordinates (n x dim, m)."""
        s = self._h5["structure"]
        if name in s:
            return
        g = s.create_group(name)
        nodes = np.asarray(nodes, dtype=np.float64)
        g.create_dataset("nodes", data=nodes)
        _series(g, "time", ())
        _series(g, "displacement", nodes.shape)

    def append_structure(self, name: str, t: float, displacement: np.ndarray) -> None:
        """Append the translational nodal displacement (nodes x dim, m) of member ``name``;
        buffered until the next flush."""
        self._buffer(f"structure/{name}", "displacement", t, displacement)

    # ------------------------------------------------------------------ coupling
    def append_coupling(self, t: float, iterations: int, residual: float, **extra: float) -> None:
        """Append one coupling window record (plus optional named scalars, e.g. energies);
        buffered until the next flush, like the other series (one resize and write per dataset
        and flush instead of one per window: 18 datasets, about 6 ms a window in h5py)."""
        self._coupling_rows.append((float(t), int(iterations), float(residual), extra))

    def _flush_coupling(self) -> None:
        """Write the buffered window records: a key first seen now is padded with NaN for the
        earlier windows, and a float key a window lacks (e.g. fictitious_force_error of a
        window in which no fictitious mass acted) reads NaN, so every column keeps one row per
        window."""
        if not self._coupling_rows:
            return
        rows, self._coupling_rows = self._coupling_rows, []
        if "coupling" not in self._h5:
            g = self._h5.create_group("coupling")
            _series(g, "time", ())
            _series(g, "iterations", (), dtype=np.int32)
            _series(g, "residual", ())
        g = self._h5["coupling"]
        n0 = g["time"].shape[0]
        keys = list(dict.fromkeys(k for *_, extra in rows for k in extra))
        for key in keys:
            if key not in g:
                ds = _series(g, key, ())
                if n0:  # a late key: NaN for the windows written before it
                    _append_rows(ds, np.full(n0, np.nan))
        _append_rows(g["time"], np.array([r[0] for r in rows], dtype=np.float64))
        _append_rows(g["iterations"], np.array([r[1] for r in rows], dtype=np.int32))
        _append_rows(g["residual"], np.array([r[2] for r in rows], dtype=np.float64))
        for key in g:
            ds = g[key]
            if key in ("time", "iterations", "residual") or ds.shape[0] != n0:
                continue
            if ds.dtype.kind != "f":
                continue
            col = np.array([r[3].get(key, np.nan) for r in rows], dtype=np.float64)
            _append_rows(ds, col.astype(ds.dtype, copy=False))

    # ------------------------------------------------------------------ momentum budget
    def add_momentum_budget(
        self, patches: Sequence[str], dim: int, unit: str, boundary_force: str
    ) -> None:
        """Declare ``/momentum_budget`` (idempotent for restarts): one row per fluid step
        (fluid-only runs) or per accepted coupling window, impulses over that period in
        ``unit``; fluid keys (T, dim), patch keys (T, patches, dim) (docs/results.md)."""
        if "momentum_budget" in self._h5:
            return
        g = self._h5.create_group("momentum_budget")
        g.attrs["unit"] = unit
        g.attrs["patches"] = list(patches)
        g.attrs["components"] = ["x", "y", "z"][:dim]
        g.attrs["boundary_force"] = boundary_force
        _series(g, "time", ())
        _series(g, "period", ())
        for key in BUDGET_FLUID_KEYS:
            _series(g, key, (dim,))
        for key in BUDGET_PATCH_KEYS:
            _series(g, f"patch_{key}", (len(patches), dim))

    def append_momentum_budget(self, t: float, period: float, record: dict) -> None:
        """Append one budget row at time ``t`` (s) over the last ``period`` (s): ``record`` as
        ``MomentumBudget.take`` returns it; buffered until the next flush."""
        names = self._h5["momentum_budget"].attrs["patches"]
        row = {k: np.asarray(record[k], dtype=np.float64) for k in BUDGET_FLUID_KEYS}
        for key in BUDGET_PATCH_KEYS:
            row[f"patch_{key}"] = (
                np.stack([record[f"{n}/{key}"] for n in names]) if len(names) else None
            )
        row["period"] = np.float64(period)
        self._budget_rows.append((float(t), row))

    def _flush_budget(self) -> None:
        if not self._budget_rows:
            return
        g = self._h5["momentum_budget"]
        rows, self._budget_rows = self._budget_rows, []
        _append_rows(g["time"], np.array([t for t, _ in rows]))
        patch_keys = tuple(f"patch_{k}" for k in BUDGET_PATCH_KEYS)
        for key in ("period", *BUDGET_FLUID_KEYS, *patch_keys):
            if rows[0][1][key] is None:
                g[key].resize(g["time"].shape[0], axis=0)
                continue
            _append_rows(g[key], np.stack([r[key] for _, r in rows]))

    # ------------------------------------------------------------------ lifecycle
    @property
    def h5(self) -> h5py.File:
        """The underlying h5py file (for readers and extensions)."""
        return self._h5

    @property
    def path(self) -> Path:
        return Path(self._h5.filename)

    def set_status(self, status: str) -> None:
        self._h5.attrs["status"] = status

    def flush(self) -> None:
        """Write buffered samples, update the wall time, push everything to disk and then bring
        the XDMF sidecar in step with the snapshots now on disk."""
        pending = (
            sum(len(v[0]) for v in self._pending.values())
            + len(self._budget_rows)
            + len(self._coupling_rows)
        )
        disk_space.require(
            self.path, 2**8 * pending, "the buffered samples", disk_space.SMALL_MARGIN_BYTES
        )
        self._flush_series()
        self._flush_budget()
        self._flush_coupling()
        self._h5.attrs["wall_time"] = self._wall_offset + time.perf_counter() - self._t_start
        self._h5.flush()
        self._write_sidecar()

    def _write_sidecar(self) -> None:
        """Rewrite the sidecar when the snapshots changed; none while there are no snapshots."""
        if self._xdmf is None or self._xdmf_snapshots == self._n_snapshots:
            return
        if self._n_snapshots == 0:
            self._xdmf.unlink(missing_ok=True)  # a sidecar of an earlier run would be stale
        else:
            write_xdmf(self._h5, self._xdmf)
        self._xdmf_snapshots = self._n_snapshots

    def close(self, status: str | None = None) -> None:
        """Set ``status``, flush and close. On a full disk (:class:`~mpsfem.results.disk_space.
        DiskFullError` from the flush) the status is still set and the file closed, readable
        up to its last flush; the buffered samples are dropped and the error re-raised."""
        if not self._h5.id.valid:
            return
        try:
            if status is not None:
                self.set_status(status)
            self.flush()
        except disk_space.DiskFullError:
            self._pending.clear()
            self._budget_rows.clear()
            self._coupling_rows.clear()
            raise
        finally:
            self._h5.close()

    def __enter__(self) -> ResultsFile:
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        self.close("finished" if exc is None else f"failed: {exc}")
