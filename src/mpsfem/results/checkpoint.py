"""Checkpoints: the complete state needed to resume a run bit for bit.

A checkpoint is a small HDF5 file with one dataset per state array and a JSON ``meta`` attribute
(time, step, next output times, ...), plus the scenario it ran: ``scenario`` (TOML text),
``overrides`` (JSON list of ``--set``) and ``scenario_resolved`` (JSON of the validated scenario),
which a restart compares with its own. It is written to a temporary name and renamed, so a run
killed while writing leaves the previous checkpoint intact.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import h5py
import numpy as np

from mpsfem import __version__

FORMAT = 1


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
    with h5py.File(tmp, "w") as h5:
        h5.attrs["format"] = FORMAT
        h5.attrs["version"] = __version__
        h5.attrs["meta"] = json.dumps(meta)
        h5.attrs["scenario"] = scenario_text
        if scenario_resolved is not None:
            h5.attrs["scenario_resolved"] = json.dumps(scenario_resolved)
        if overrides is not None:
            h5.attrs["overrides"] = json.dumps(list(overrides))
        for group, items in arrays.items():
            g = h5.create_group(group)
            for name, arr in items.items():
                g.create_dataset(name, data=np.asarray(arr))
    os.replace(tmp, path)
    return path


def _open(path: str | Path) -> h5py.File:
    """Open a checkpoint for reading; a missing, unreadable or foreign file is refused."""
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"checkpoint {str(path)!r} does not exist")
    try:
        h5 = h5py.File(path, "r")
    except OSError as exc:
        raise ValueError(f"{path}: not a readable checkpoint ({exc})") from None
    if int(h5.attrs.get("format", -1)) != FORMAT:
        h5.close()
        raise ValueError(f"{path}: not a checkpoint of format {FORMAT}")
    return h5


def read_checkpoint(path: str | Path) -> tuple[dict[str, dict[str, np.ndarray]], dict, str]:
    """Read a checkpoint: (arrays, meta, scenario text)."""
    with _open(path) as h5:
        meta = json.loads(h5.attrs["meta"])
        text = str(h5.attrs["scenario"])
        arrays = {g: {k: ds[()] for k, ds in h5[g].items()} for g in h5}
    return arrays, meta, text


def read_checkpoint_scenario(path: str | Path) -> tuple[dict | None, str, list[str] | None]:
    """The scenario a checkpoint ran: (validated scenario or None, TOML text, overrides or None).

    None where the checkpoint predates storing it."""
    with _open(path) as h5:
        resolved = h5.attrs.get("scenario_resolved")
        overrides = h5.attrs.get("overrides")
        text = str(h5.attrs.get("scenario", ""))
    return (
        json.loads(resolved) if resolved is not None else None,
        text,
        json.loads(overrides) if overrides is not None else None,
    )
