"""Differences between two resolved scenarios, as a restart checks them against its checkpoint.

A restart continues a run bit for bit only under the same physics and numerics. What may change
is what a run writes and how long it lasts (``run.*``, ``output.*``, a probe's ``interval``,
``structure.record_interval``), the title, how the participants talk (``coupling.transport.*``)
and how hard an implicit window iterates (``coupling.convergence.*``: the remedy after a window
that did not converge). Everything else must be equal.
"""

from __future__ import annotations

import re
from typing import Any

from pydantic import BaseModel, TypeAdapter
from pydantic_core import PydanticUndefined

#: dotted keys (regular expressions, matched from the start) a restart may change
RESTART_FREE_KEYS = (
    r"title$",
    r"run\.",
    r"output\.",
    r"probes\[\d+\]\.interval$",
    r"structure\.record_interval$",
    r"coupling\.transport\.",
    r"coupling\.convergence\.",
    # how the fictitious mass's wet set is updated inside a window: it changes the path of the
    # coupling iterations, not the fixed point they converge to (as coupling.convergence.*)
    r"structure\.members\[\d+\]\.fictitious_wet_update$",
)
#: the same, as the error message and the docs write them
RESTART_FREE_TEXT = (
    "title, run.*, output.*, probes[*].interval, structure.record_interval, "
    "coupling.transport.*, coupling.convergence.*, structure.members[*].fictitious_wet_update"
)
_FREE = re.compile("|".join(f"(?:{k})" for k in RESTART_FREE_KEYS))

ABSENT = "(absent)"


def _flatten(value: Any, key: str, out: dict[str, Any]) -> None:
    if isinstance(value, dict):
        for k, v in value.items():
            _flatten(v, f"{key}.{k}" if key else str(k), out)
    elif isinstance(value, list) and any(isinstance(v, dict) for v in value):
        out[f"{key} (items)"] = len(value)  # a list of tables: its length, then each table
        for i, v in enumerate(value):
            _flatten(v, f"{key}[{i}]", out)
    else:
        out[key] = value


def flatten(scenario: dict) -> dict[str, Any]:
    """``{"fluid": {"blocks": [{"lower": [0, 0]}]}}`` -> ``{"fluid.blocks[0].lower": [0, 0],
    "fluid.blocks (items)": 1}``."""
    out: dict[str, Any] = {}
    _flatten(scenario, "", out)
    return out


def restart_differences(checkpoint: dict, now: dict) -> list[tuple[str, Any, Any]]:
    """(dotted key, checkpoint's value, this run's value) for every key outside
    :data:`RESTART_FREE_KEYS` that differs; a key only one side has shows ``(absent)``."""
    a, b = flatten(checkpoint), flatten(now)
    out = []
    for key in sorted(set(a) | set(b)):
        if _FREE.match(key):
            continue
        va, vb = a.get(key, ABSENT), b.get(key, ABSENT)
        if va != vb:
            out.append((key, va, vb))
    return out


_PART = re.compile(r"([^.\[\]]+)((?:\[\d+\])*)")


def at_schema_default(model: BaseModel, key: str, value: Any) -> bool:
    """True if the dotted ``key`` (as :func:`flatten` writes it) names a field of the validated
    ``model`` whose schema default, in JSON form, is ``value``: a key a checkpoint written
    before the field existed lacks, and this run leaves at the default."""
    parts = _PART.findall(key)
    if not parts or ".".join(p + i for p, i in parts) != key:
        return False
    node: Any = model
    for n, (name, index) in enumerate(parts):
        if not isinstance(node, BaseModel) or name not in type(node).model_fields:
            return False
        if n == len(parts) - 1 and not index:
            field = type(node).model_fields[name]
            if field.default is PydanticUndefined:
                return False
            default = field.get_default(call_default_factory=True)
            return TypeAdapter(field.annotation).dump_python(default, mode="json") == value
        node = getattr(node, name)
        for i in re.findall(r"\d+", index):
            if not isinstance(node, list) or int(i) >= len(node):
                return False
            node = node[int(i)]
    return False
