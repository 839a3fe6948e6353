"""Checkpoints: the complete state needed to resume a run bit for bit.

A checkpoint is a small HDF5 file with one dataset per state array and a JSON ``meta`` text
(time, step, next output times, ...), plus the scenario it ran: ``scenario`` (TOML text),
``overrides`` (JSON list of ``--set``) and ``scenario_resolved`` (JSON of the validated scenario),
which a restart compares with its own. It is written to a temporary name and renamed, so a run
killed while writing leaves the previous checkpoint intact.

Texts are UTF-8 byte arrays in the group ``_text`` (format 2), not string attributes (format 1):
a variable-length string lives in HDF5's global heap, and a damaged heap makes the library's
reader loop forever (found by tests/foundation/test_fuzz_inputs.py). A byte array is read like
any other array, after its size is checked. The only attribute is the integer ``format``.
"""

from __future__ import annotations

import contextlib
import json
import math
import os
from collections.abc import Iterator
from pathlib import Path

import h5py
import numpy as np

from mpsfem import __version__
from mpsfem.results import disk_space

FORMAT = 2
#: the group that holds a checkpoint's texts (UTF-8 bytes), not a participant's arrays
TEXT_GROUP = "_text"


def default_checkpoint_path(results_path: str | Path) -> Path:
    """``run.h5`` -> ``run.ckpt.h5`` beside it."""
    p = Path(results_path)
    return p.with_name(p.stem + ".ckpt.h5")


def write_checkpoint(
    path: str | Path,
    arrays: dict[str, dict[str, np.ndarray]],
    meta: dict,
    scenario_text: str,
    scenario_resolved: dict | None = None,
    overrides: list[str] | None = None,
) -> Path:
    """Write ``arrays`` (participant name -> array name -> array) and ``meta`` atomically, with
    the scenario (TOML text, and where given the validated scenario and the ``--set`` list)."""
    path = Path(path)
    tmp = path.with_name(path.name + ".tmp")
    size = sum(np.asarray(a).nbytes for items in arrays.values() for a in items.values())
    disk_space.require(path, size + len(scenario_text) + 2**16, f"the checkpoint {path.name}")
    try:
        _write_file(tmp, arrays, meta, scenario_text, scenario_resolved, overrides)
    except BaseException:
        tmp.unlink(missing_ok=True)  # the previous checkpoint stays as it was
        raise
    os.replace(tmp, path)
    return path


def _write_file(tmp, arrays, meta, scenario_text, scenario_resolved, overrides) -> None:
    with h5py.File(tmp, "w") as h5:
        h5.attrs["format"] = np.int64(FORMAT)
        texts = {"version": __version__, "meta": json.dumps(meta), "scenario": scenario_text}
        if scenario_resolved is not None:
            texts["scenario_resolved"] = json.dumps(scenario_resolved)
        if overrides is not None:
            texts["overrides"] = json.dumps(list(overrides))
        g = h5.create_group(TEXT_GROUP)
        for name, text in texts.items():
            g.create_dataset(name, data=np.frombuffer(text.encode("utf-8"), dtype=np.uint8))
        for group, items in arrays.items():
            g = h5.create_group(group)
            for name, arr in items.items():
                g.create_dataset(name, data=np.asarray(arr))


class CheckpointError(ValueError):
    """A checkpoint file that cannot be trusted: named by its path, dataset and what is wrong."""


#: most datasets a checkpoint may hold (ours hold a few dozen)
MAX_DATASETS = 10_000
#: space dimensions of the fluid's arrays
FLUID_DIMS = (2, 3)


def _open(path: str | Path) -> h5py.File:
    """Open a checkpoint for reading; a missing, unreadable or foreign file is refused."""
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"checkpoint {str(path)!r} does not exist")
    try:
        h5 = h5py.File(path, "r")
    except OSError as exc:
        raise CheckpointError(f"{path}: not a readable checkpoint ({exc})") from None
    fmt = -1
    try:
        # the attribute's type is in the object header: check it before reading any value, so
        # that a string (heap-stored) format is never read
        if "format" in h5.attrs and h5.attrs.get_id("format").dtype.kind in "iu":
            fmt = int(np.asarray(h5.attrs["format"]).reshape(-1)[0])
    except (TypeError, ValueError, OSError, IndexError):
        fmt = -1
    if fmt != FORMAT:
        h5.close()
        older = " (format 1 was written by mpsfem before 2026-11-26)" if fmt == 1 else ""
        raise CheckpointError(f"{path}: not a checkpoint of format {FORMAT}{older}")
    return h5


def _text(h5: h5py.File, name: str, path: Path, required: bool = True) -> str | None:
    """The text ``name`` of the ``_text`` group, decoded (None where absent and not required)."""
    if TEXT_GROUP not in _hard_members(h5, path, ""):
        raise CheckpointError(f"{path}: the group {TEXT_GROUP!r} of its texts is missing")
    group = h5[TEXT_GROUP]
    if not isinstance(group, h5py.Group):
        raise CheckpointError(f"{path}: {TEXT_GROUP} is a dataset; a group of texts expected")
    if name not in _hard_members(group, path, f"{TEXT_GROUP}/"):
        if required:
            raise CheckpointError(f"{path}: text {name!r} is missing")
        return None
    ds = group[name]
    if not isinstance(ds, h5py.Dataset):
        raise CheckpointError(f"{path}: {TEXT_GROUP}/{name} is no array of bytes")
    raw = _read_dataset(ds, path, path.stat().st_size)
    if raw.dtype != np.uint8 or raw.ndim != 1:
        raise CheckpointError(
            f"{path}: {TEXT_GROUP}/{name} has type {raw.dtype} and shape {raw.shape}; "
            "a 1-D array of bytes (uint8) is expected"
        )
    return raw.tobytes().decode("utf-8", errors="replace")


def _text_json(h5: h5py.File, name: str, path: Path, required: bool = True):
    """The JSON text ``name`` decoded (None where absent and not required)."""
    raw = _text(h5, name, path, required)
    if raw is None:
        return None
    try:
        return json.loads(raw)
    except (ValueError, RecursionError) as exc:
        raise CheckpointError(f"{path}: text {name!r} is not valid JSON ({exc})") from None


def _hard_members(group: h5py.Group, path: Path, where: str) -> list[str]:
    """Names in ``group``, each a hard link (external and soft links are refused unfollowed)."""
    names = list(group.keys())
    for name in names:
        link = group.get(name, getlink=True)
        if not isinstance(link, h5py.HardLink):
            kind = type(link).__name__
            raise CheckpointError(
                f"{path}: {where}{name} is a {kind}; a checkpoint holds only its own data "
                "(links to other files or paths are not followed)"
            )
    return names


def _read_dataset(ds: h5py.Dataset, path: Path, budget: int) -> np.ndarray:
    """The dataset's array, after checking its storage, type and size (nothing read before)."""
    name = ds.name.lstrip("/")
    if ds.is_virtual or ds.external:
        raise CheckpointError(f"{path}: {name} keeps its data in another file; refused")
    if ds.dtype.kind not in "biuf":
        raise CheckpointError(f"{path}: {name} has type {ds.dtype}; a number array is expected")
    if ds.ndim > 2:
        raise CheckpointError(f"{path}: {name} has {ds.ndim} dimensions; at most 2 expected")
    nbytes = int(np.prod(ds.shape, dtype=np.float64) * ds.dtype.itemsize)
    if nbytes > budget:
        raise CheckpointError(
            f"{path}: {name} declares shape {ds.shape} ({nbytes} bytes), more than the file's "
            f"{budget} bytes: refused (a checkpoint stores its arrays uncompressed)"
        )
    arr = ds[()]
    if arr.dtype.kind == "f" and not np.all(np.isfinite(arr)):
        bad = np.argwhere(~np.isfinite(arr))[0].tolist()
        raise CheckpointError(f"{path}: {name} holds a non-finite value at index {bad}")
    return arr


def _number(value, where: str, path: Path, low: float = -math.inf, integer: bool = False):
    """``value`` as a finite number >= ``low`` (an int where ``integer``), else refused."""
    ok = isinstance(value, int | float) and not isinstance(value, bool)
    if ok and integer:
        ok = isinstance(value, int) or (isinstance(value, float) and value.is_integer())
    if not ok or not math.isfinite(value) or value < low:
        kind = "a whole number" if integer else "a finite number"
        raise CheckpointError(f"{path}: {where} = {value!r}: must be {kind} >= {low:g}")
    return int(value) if integer else float(value)


def _check_time(value, where: str, path: Path, end_time: float | None) -> None:
    """A time of the run: finite, >= 0 and not past the run's end."""
    t = _number(value, where, path, low=0.0)
    if end_time is not None and t > end_time * (1.0 + 1e-9) + 1e-12:
        raise CheckpointError(
            f"{path}: {where} = {t!r} lies past the end of this run (t = {end_time} s); refused"
        )


def _check_csr(arrays: dict, prefix: str, shape: tuple[int, int], path: Path) -> None:
    """``prefix``_indptr/_indices/_data form a CSR matrix of ``shape`` with in-range indices."""
    rows, cols = shape
    try:
        indptr, indices, data = (arrays[f"{prefix}_{p}"] for p in ("indptr", "indices", "data"))
    except KeyError as exc:
        raise CheckpointError(f"{path}: fluid_preconditioner/{exc.args[0]} is missing") from None
    where = f"{path}: fluid_preconditioner/{prefix}"
    for arr, part in ((indptr, "indptr"), (indices, "indices")):
        if arr.ndim != 1 or arr.dtype.kind not in "iu":
            raise CheckpointError(f"{where}_{part}: must be a 1-D integer array")
    if data.ndim != 1 or data.dtype.kind != "f":
        raise CheckpointError(f"{where}_data: must be a 1-D float array")
    if indptr.shape[0] != rows + 1:
        raise CheckpointError(
            f"{where}_indptr: has {indptr.shape[0]} entries; a {rows} x {cols} matrix needs "
            f"{rows + 1}"
        )
    nnz = indices.shape[0]
    if data.shape[0] != nnz:
        raise CheckpointError(f"{where}_data: has {data.shape[0]} entries, indices {nnz}")
    if indptr[0] != 0 or indptr[-1] != nnz or np.any(np.diff(indptr.astype(np.int64)) < 0):
        raise CheckpointError(
            f"{where}_indptr: must start at 0, never decrease and end at the {nnz} stored entries"
        )
    if nnz and (indices.min() < 0 or indices.max() >= cols):
        raise CheckpointError(
            f"{where}_indices: column indices {indices.min()} .. {indices.max()} leave the "
            f"matrix's {cols} columns"
        )


def _check_preconditioner(arrays: dict, meta, n_particles: int | None, path: Path) -> None:
    """The pressure solver's AMG hierarchy: sizes, CSR structure and index ranges."""
    if meta is None:
        if arrays:
            raise CheckpointError(f"{path}: fluid_preconditioner arrays without their meta")
        return
    if not isinstance(meta, dict):
        raise CheckpointError(f"{path}: meta fluid_preconditioner is not a table")
    if not meta.get("built", False):
        return
    sizes = meta.get("sizes")
    if not isinstance(sizes, list) or len(sizes) < 1:
        raise CheckpointError(f"{path}: meta fluid_preconditioner.sizes must be a list of sizes")
    sizes = [
        _number(m, f"fluid_preconditioner.sizes[{i}]", path, 1, integer=True)
        for i, m in enumerate(sizes)
    ]
    if n_particles is not None and sizes[0] > n_particles:
        raise CheckpointError(
            f"{path}: fluid_preconditioner.sizes[0] = {sizes[0]} exceeds the {n_particles} "
            "particles of fluid/pos"
        )
    _number(meta.get("base_rate"), "fluid_preconditioner.base_rate", path)
    for i in range(len(sizes) - 1):
        m, mc = sizes[i], sizes[i + 1]
        if i > 0:
            _check_csr(arrays, f"L{i}_A", (m, m), path)
        _check_csr(arrays, f"L{i}_P", (m, mc), path)
        _check_csr(arrays, f"L{i}_R", (mc, m), path)
    inv = arrays.get("coarse_inv")
    if inv is None or inv.shape != (sizes[-1], sizes[-1]) or inv.dtype.kind != "f":
        got = None if inv is None else inv.shape
        raise CheckpointError(
            f"{path}: fluid_preconditioner/coarse_inv has shape {got}; the coarsest size "
            f"{sizes[-1]} needs ({sizes[-1]}, {sizes[-1]})"
        )


def _check_fluid(arrays: dict, path: Path) -> int | None:
    """Shapes of the fluid's state arrays agree (n particles, dim 2 or 3); returns n."""
    pos = arrays.get("pos")
    if pos is None:
        return None
    if pos.ndim != 2 or pos.shape[1] not in FLUID_DIMS or pos.dtype.kind != "f":
        raise CheckpointError(f"{path}: fluid/pos has shape {pos.shape}; (n, 2 or 3) expected")
    n, d = pos.shape
    want = {"vel": (n, d), "grad_p": (n, d), "lap_u": (n, d), "p": (n,)}
    for name, shape in want.items():
        arr = arrays.get(name)
        if arr is not None and (arr.shape != shape or arr.dtype.kind != "f"):
            raise CheckpointError(
                f"{path}: fluid/{name} has shape {arr.shape}; fluid/pos gives {shape}"
            )
    return n


def check_checkpoint(
    arrays: dict[str, dict[str, np.ndarray]], meta, path: Path, end_time: float | None = None
) -> None:
    """Everything a restart reads is consistent before any of it is used (CheckpointError)."""
    if not isinstance(meta, dict):
        raise CheckpointError(f"{path}: attribute 'meta' is not a table")
    coupled = meta.get("kind") == "coupled"
    groups = ("fluid", "structure", "scheme") if coupled else ("fluid",)
    for group in groups:
        if group not in arrays or not isinstance(meta.get(group), dict):
            raise CheckpointError(f"{path}: the {group!r} state (group and meta) is missing")
    n = _check_fluid(arrays["fluid"], path)
    fluid_meta = meta["fluid"]
    if not coupled or "t" in fluid_meta:
        _check_time(fluid_meta.get("t"), "meta fluid.t", path, end_time)
    if "step" in fluid_meta:
        _number(fluid_meta["step"], "meta fluid.step", path, 0, integer=True)
    if "dt_next" in fluid_meta:
        dt = _number(fluid_meta["dt_next"], "meta fluid.dt_next", path, 0.0)
        if dt == 0.0:
            raise CheckpointError(f"{path}: meta fluid.dt_next = 0.0: must be > 0")
    if coupled:
        for key in ("t", "t0"):
            _check_time(meta["scheme"].get(key), f"meta scheme.{key}", path, end_time)
        _number(meta["scheme"].get("index"), "meta scheme.index", path, 0, integer=True)
        _number(meta["scheme"].get("window"), "meta scheme.window", path, 0.0)
    _check_preconditioner(
        arrays.get("fluid_preconditioner", {}), meta.get("fluid_preconditioner"), n, path
    )
    probes = meta.get("next_probe", {})
    if not isinstance(probes, dict):
        raise CheckpointError(f"{path}: meta next_probe is not a table")
    for name, t in probes.items():
        _number(t, f"meta next_probe.{name}", path, 0.0)
    schedule = meta.get("schedule", {}) if coupled else meta
    for key in ("next_snapshot", "next_checkpoint"):
        if key in schedule:
            value = schedule[key]
            if value != math.inf:  # 'never' is written as Infinity
                _number(value, f"meta {key}", path, 0.0)
        elif not coupled:
            raise CheckpointError(f"{path}: meta {key} is missing")


@contextlib.contextmanager
def _damage_as_error(path: Path) -> Iterator[None]:
    """What the HDF5 library raises on a damaged file (OSError, KeyError, ...) as a
    :class:`CheckpointError` naming the file."""
    try:
        yield
    except CheckpointError:
        raise
    except (OSError, KeyError, RuntimeError, TypeError, ValueError, UnicodeError) as exc:
        raise CheckpointError(f"{path}: damaged or not a checkpoint ({exc})") from None


def read_checkpoint(
    path: str | Path, end_time: float | None = None
) -> tuple[dict[str, dict[str, np.ndarray]], dict, str]:
    """Read a checkpoint: (arrays, meta, scenario text), every array and number checked first
    (:func:`check_checkpoint`); a file that fails a check raises :class:`CheckpointError`.

    ``end_time``: the end of the run that continues from it; a checkpoint time past it is
    refused. (Not the stored ``run.end_time``: a run continued with ``--end-time`` writes
    checkpoints past it.)"""
    path = Path(path)
    budget = path.stat().st_size
    with _damage_as_error(path), _open(path) as h5:
        meta = _text_json(h5, "meta", path)
        text = _text(h5, "scenario", path, required=False) or ""
        arrays: dict[str, dict[str, np.ndarray]] = {}
        count = 0
        for g in _hard_members(h5, path, ""):
            if g == TEXT_GROUP:
                continue
            group = h5[g]
            if not isinstance(group, h5py.Group):
                raise CheckpointError(f"{path}: {g} is a dataset; groups of arrays expected")
            arrays[g] = {}
            for k in _hard_members(group, path, f"{g}/"):
                ds = group[k]
                count += 1
                if not isinstance(ds, h5py.Dataset) or count > MAX_DATASETS:
                    raise CheckpointError(
                        f"{path}: {g}/{k} is no array, or there are more than {MAX_DATASETS}"
                    )
                arrays[g][k] = _read_dataset(ds, path, budget)
    check_checkpoint(arrays, meta, path, end_time)
    return arrays, meta, text


def read_checkpoint_scenario(path: str | Path) -> tuple[dict | None, str, list[str] | None]:
    """The scenario a checkpoint ran: (validated scenario or None, TOML text, overrides or None).

    None where the checkpoint predates storing it."""
    path = Path(path)
    with _damage_as_error(path), _open(path) as h5:
        resolved = _text_json(h5, "scenario_resolved", path, required=False)
        overrides = _text_json(h5, "overrides", path, required=False)
        text = _text(h5, "scenario", path, required=False) or ""
    if resolved is not None and not isinstance(resolved, dict):
        raise CheckpointError(f"{path}: text 'scenario_resolved' is not a table")
    if overrides is not None and not (
        isinstance(overrides, list) and all(isinstance(o, str) for o in overrides)
    ):
        raise CheckpointError(f"{path}: text 'overrides' is not a list of strings")
    return resolved, text, overrides
