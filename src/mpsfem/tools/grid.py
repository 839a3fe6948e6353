"""Parameter grids of ``mpsfem sweep``: ``--grid key=v1,v2,...`` axes, their Cartesian product
and a deterministic name per case.

Values are TOML literals or bare words, as for ``--set`` (``0.004``, ``implicit`` or
``"implicit"``, ``[0.0, -100.0]``); commas inside brackets, braces or quotes do not separate
values (a bare word has no comma, so it cannot be split). Each value is written back as a
canonical TOML literal (``1e-2`` and ``0.01`` are the same case), which is what the case name and
the child's ``--set`` use.
"""

from __future__ import annotations

import hashlib
import itertools
import json
import math
import re
from dataclasses import dataclass
from typing import Any

from mpsfem.scenario.base import ScenarioError
from mpsfem.scenario.loader import parse_override

#: a case name longer than this is cut and ends in a hash of its parameters
MAX_NAME = 100
_UNSAFE = re.compile(r"[^A-Za-z0-9._+=-]")


def split_literals(raw: str) -> list[str]:
    """Split ``raw`` at the commas that are outside brackets, braces and quoted strings."""
    parts, depth, quote, start, i = [], 0, "", 0, 0
    while i < len(raw):
        ch = raw[i]
        if quote:
            if ch == "\\" and quote == '"':
                i += 1  # skip the escaped character
            elif ch == quote:
                quote = ""
        elif ch in "\"'":
            quote = ch
        elif ch in "[{":
            depth += 1
        elif ch in "]}":
            depth -= 1
        elif ch == "," and depth == 0:
            parts.append(raw[start:i])
            start = i + 1
        i += 1
    parts.append(raw[start:])
    return [p.strip() for p in parts]


def toml_literal(value: Any) -> str:
    """Canonical TOML literal of a parsed TOML value (round-trips through ``tomllib``)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if math.isnan(value):
            return "nan"
        if math.isinf(value):
            return "inf" if value > 0 else "-inf"
        return repr(value)
    if isinstance(value, str):
        return json.dumps(value)  # a TOML basic string (JSON escapes are TOML escapes)
    if isinstance(value, list):
        return "[" + ", ".join(toml_literal(v) for v in value) + "]"
    if isinstance(value, dict):
        items = ", ".join(f"{json.dumps(k)} = {toml_literal(v)}" for k, v in value.items())
        return "{" + items + "}"
    raise TypeError(f"no TOML literal for {type(value).__name__} {value!r}")


@dataclass(frozen=True)
class GridAxis:
    """One ``--grid key=v1,v2,...``: the dotted key and its values (parsed, canonical literals)."""

    key: str
    values: tuple[Any, ...]
    literals: tuple[str, ...]

    @property
    def numeric(self) -> bool:
        """All values are (non-boolean) numbers."""
        return all(isinstance(v, int | float) and not isinstance(v, bool) for v in self.values)


def parse_grid_arg(arg: str) -> GridAxis:
    """Parse ``key=v1,v2,...``; errors read like those of ``--set``."""
    if "=" not in arg:
        raise ScenarioError([f"--grid {arg!r}: expected key=v1,v2,... with TOML literal values"])
    key, _, raw = arg.partition("=")
    key = key.strip()
    pieces = split_literals(raw)
    if any(p == "" for p in pieces):
        raise ScenarioError([f"--grid {arg!r}: an empty value (two commas, or one at an end)"])
    values, literals = [], []
    for piece in pieces:
        try:
            _, value = parse_override(f"{key}={piece}", bare_words=True)
        except ScenarioError as exc:
            raise ScenarioError(
                [p.replace("--set", "--grid", 1) for p in exc.problems], exc.source
            ) from None
        lit = toml_literal(value)
        if lit in literals:
            raise ScenarioError([f"--grid {key}: value {piece} is given twice"])
        values.append(value)
        literals.append(lit)
    return GridAxis(key, tuple(values), tuple(literals))


def short_keys(keys: list[str]) -> dict[str, str]:
    """The shortest dotted suffix of each key that no other key ends with
    (``structure.members.0.thickness`` -> ``thickness``)."""
    out = {}
    for key in keys:
        parts = key.split(".")
        for n in range(1, len(parts) + 1):
            cand = ".".join(parts[-n:])
            if not any(o != key and (o == cand or o.endswith("." + cand)) for o in keys):
                break
        out[key] = cand
    return out


@dataclass(frozen=True)
class Case:
    """One point of the grid: ``index`` (0-based, in product order), parameters, name."""

    index: int
    params: tuple[tuple[str, Any], ...]  # (dotted key, value) in grid-axis order
    literals: tuple[str, ...]
    name: str
    label: str  # short human form: "thickness=0.01 force=[0.0, -100.0]"

    def overrides(self) -> list[str]:
        """``--set`` items of this case (``key=literal``)."""
        return [f"{k}={lit}" for (k, _), lit in zip(self.params, self.literals, strict=True)]


def case_name(items: list[tuple[str, str]]) -> str:
    """Directory-safe deterministic name from (short key, literal) pairs; characters outside
    ``[A-Za-z0-9._+=-]`` become ``_`` and then, as when the name is cut, a hash is appended so
    different parameters never share a name."""
    raw = "__".join(f"{k}={lit}" for k, lit in items).replace(", ", ",")
    safe = _UNSAFE.sub("_", raw)
    if safe == raw and len(raw) <= MAX_NAME:
        return raw
    return f"{safe[:MAX_NAME]}-{_digest(raw)}"


def _digest(text: str) -> str:
    return hashlib.sha1(text.encode()).hexdigest()[:8]


def make_cases(axes: list[GridAxis]) -> list[Case]:
    """The Cartesian product of ``axes`` (first axis slowest), each case named."""
    keys = [a.key for a in axes]
    dup = sorted({k for k in keys if keys.count(k) > 1})
    if dup:
        raise ScenarioError(
            [f"--grid {k}: given more than once (list all values in one --grid)" for k in dup]
        )
    short = short_keys(keys)
    cases = []
    choices = [list(zip(a.values, a.literals, strict=True)) for a in axes]
    for index, combo in enumerate(itertools.product(*choices)):
        params = tuple((k, v) for k, (v, _) in zip(keys, combo, strict=True))
        lits = tuple(lit for _, lit in combo)
        pairs = [(short[k], lit) for k, lit in zip(keys, lits, strict=True)]
        label = " ".join(f"{k}={lit}" for k, lit in pairs)
        # strings appear bare in names ("scheme=implicit"), every other value as its literal
        bare = [
            (short[k], v if isinstance(v, str) else lit)
            for (k, v), lit in zip(params, lits, strict=True)
        ]
        cases.append(Case(index, params, lits, case_name(bare), label))
    names = [c.name for c in cases]
    if len(set(names)) < len(names):  # e.g. "1" and 1 on one axis: tell them apart by a hash
        cases = [
            Case(c.index, c.params, c.literals, f"{c.name}-{_digest(c.label)}", c.label)
            for c in cases
        ]
    return cases
