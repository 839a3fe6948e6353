"""Read a scenario TOML file, apply ``--set key=value`` overrides and validate it.

Every problem is reported before any compute starts, as ``<dotted key> = <value given>: <what is
allowed>``; unknown keys list the keys that are allowed at that place.
"""

from __future__ import annotations

import difflib
import re
import tomllib
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal, get_args, get_origin

from pydantic import BaseModel, ValidationError

from mpsfem.scenario.base import InvalidValue, ScenarioError
from mpsfem.scenario.schema import Scenario


@dataclass
class LoadedScenario:
    """A validated scenario together with its provenance."""

    scenario: Scenario
    text: str
    overrides: list[str] = field(default_factory=list)
    path: Path | None = None

    @property
    def stem(self) -> str:
        return self.path.stem if self.path else "scenario"

    def resolve(self, relative: str) -> Path:
        """Path of a file named in the scenario, relative to the scenario file's folder."""
        p = Path(relative)
        if p.is_absolute() or self.path is None:
            return p
        return self.path.parent / p


def _split_key(key: str) -> list[str | int]:
    parts: list[str | int] = []
    for raw in key.split("."):
        if raw == "":
            raise ValueError("empty path segment")
        parts.append(int(raw) if raw.isdigit() else raw)
    return parts


#: an unquoted ``--set`` value taken as a string when it is no TOML literal (a shell strips the
#: quotes of ``--set key="name"``); ``true``, ``false``, ``inf`` and ``nan`` stay TOML literals
BARE_WORD = re.compile(r"[A-Za-z_][A-Za-z0-9_.-]*")


def parse_override(item: str, bare_words: bool = False) -> tuple[str, Any]:
    """Parse ``key=value`` where value is a TOML literal (``0.004``, ``"implicit"``, ``[0, 1]``).

    With ``bare_words`` a value that is no TOML literal but a bare word (``pcg_jacobi``: letters,
    digits, ``_``, ``.``, ``-``, starting with a letter or ``_``) is taken as that string, so
    ``--set key="name"`` works after a shell has stripped its quotes.
    """
    if "=" not in item:
        raise ScenarioError([f"--set {item!r}: expected key=value with a TOML literal value"])
    key, _, raw = item.partition("=")
    key = key.strip()
    try:
        _split_key(key)
    except ValueError:
        raise ScenarioError([f"--set {item!r}: key {key!r} is not a dotted path"]) from None
    raw = raw.strip()
    try:
        value = tomllib.loads(f"v = {raw}")["v"]
    except RecursionError:
        raise ScenarioError(
            [f"--set {key}: the value is nested too deep (at most {MAX_NESTING} levels)"]
        ) from None
    except tomllib.TOMLDecodeError:
        if bare_words and BARE_WORD.fullmatch(raw):
            return key, raw
        strings = (
            f"strings as a bare word, {key}=name, or quoted, '{key}=\"a name\"'"
            if bare_words
            else f'strings need quotes, e.g. {key}="name"'
        )
        raise ScenarioError(
            [
                f"--set {key} = {raw!r}: not a TOML literal ({strings}; numbers as 0.004; lists "
                "as [0.0, 1.0])"
            ]
        ) from None
    return key, value


def apply_override(data: dict, key: str, value: Any) -> None:
    """Set ``value`` at dotted ``key`` (list items by index: ``probes.0.position``)."""
    parts = _split_key(key)
    node: Any = data
    for depth, part in enumerate(parts[:-1]):
        where = ".".join(str(p) for p in parts[:depth]) or "(top level)"
        if isinstance(part, int):
            if not isinstance(node, list) or part >= len(node):
                n = len(node) if isinstance(node, list) else 0
                raise ScenarioError([f"--set {key}: {where} has no item {part} (it has {n})"])
            node = node[part]
        else:
            if not isinstance(node, dict):
                raise ScenarioError([f"--set {key}: {where} is not a table"])
            node = node.setdefault(part, {})
    last = parts[-1]
    if isinstance(last, int):
        if not isinstance(node, list) or last >= len(node):
            raise ScenarioError([f"--set {key}: no list item {last} there"])
        node[last] = value
    else:
        if not isinstance(node, dict):
            raise ScenarioError([f"--set {key}: the parent of {last!r} is not a table"])
        node[last] = value


def _model_at(loc: Sequence[str | int]) -> type[BaseModel] | None:
    """The model class whose field set applies at ``loc`` (for 'allowed keys' hints).

    Inside a union of tables tagged by ``kind`` or ``type`` (pydantic puts the tag value in the
    location), the member with that tag is chosen."""
    model: Any = Scenario
    candidates: list[type[BaseModel]] = []
    for part in loc:
        if isinstance(part, int):
            continue
        if candidates:
            tagged = [m for m in candidates if part in _tags(m)]
            if tagged:
                model, candidates = tagged[0], []
                continue
            model, candidates = candidates[0], []
        if not (isinstance(model, type) and issubclass(model, BaseModel)):
            return None
        f = model.model_fields.get(part)
        if f is None:
            return None
        found = _models_in(f.annotation)
        if len(found) > 1:
            candidates = found
            model = None
        else:
            model = found[0] if found else None
    if candidates:
        return candidates[0]
    return model if isinstance(model, type) and issubclass(model, BaseModel) else None


def _models_in(ann: Any) -> list[type[BaseModel]]:
    if isinstance(ann, type) and issubclass(ann, BaseModel):
        return [ann]
    return [m for a in get_args(ann) for m in _models_in(a)]


def _tags(model: type[BaseModel]) -> set[str]:
    out: set[str] = set()
    for tag in ("kind", "type"):
        f = model.model_fields.get(tag)
        if f is not None and get_origin(f.annotation) is Literal:
            out.update(str(a) for a in get_args(f.annotation))
    return out


def _dotted(loc: Sequence[str | int]) -> str:
    out = ""
    for part in loc:
        if isinstance(part, int):
            out += f"[{part}]"
        else:
            out += ("." if out else "") + str(part)
    return out or "(top level)"


def _without_tags(loc: Sequence[str | int]) -> list[str | int]:
    """Drop the union-tag entries pydantic inserts (``probes.0.pressure.radius``)."""
    out: list[str | int] = []
    model: Any = Scenario
    candidates: list[type[BaseModel]] = []
    for part in loc:
        if isinstance(part, int):
            out.append(part)
            continue
        if candidates:
            tagged = [m for m in candidates if part in _tags(m)]
            candidates = []
            if tagged:
                model = tagged[0]
                continue
        out.append(part)
        f = model.model_fields.get(part) if isinstance(model, type) else None
        if f is None:
            model = None
            continue
        found = _models_in(f.annotation)
        if len(found) > 1:
            candidates, model = found, None
        else:
            model = found[0] if found else None
    return out


def format_validation_error(err: ValidationError) -> list[str]:
    """One line per problem: dotted key, value given, what is allowed."""
    lines = []
    for e in err.errors(include_url=False):
        loc = _without_tags(e["loc"])
        key = _dotted(loc)
        msg = e["msg"]
        if e["type"] == "extra_forbidden":
            parent = _model_at(list(e["loc"])[:-1])
            allowed = sorted(parent.model_fields) if parent else []
            last = str(e["loc"][-1])
            close = difflib.get_close_matches(last, allowed, n=1)
            hint = f"; did you mean {close[0]!r}?" if close else ""
            lines.append(f"{key}: unknown key; allowed here: {', '.join(allowed)}{hint}")
            continue
        if e["type"] == "missing":
            lines.append(f"{key}: required key is missing")
            continue
        cause = (e.get("ctx") or {}).get("error")
        if isinstance(cause, InvalidValue):  # a cross-key check naming the key inside its table
            key = _join_key(key, cause.key)
            if cause.has_value:
                lines.append(f"{key} = {cause.value!r}: {cause.message}")
            else:
                lines.append(f"{key}: {cause.message}")
            continue
        given = e.get("input")
        msg = _our_wording(e["type"], e.get("ctx") or {}, msg.removeprefix("Value error, "))
        if _is_table(given):
            lines.append(f"{key}: {msg}")  # a whole table's check: no dump of the table
        else:
            lines.append(f"{key} = {given!r}: {msg}")
    return lines


def _our_wording(kind: str, ctx: dict, msg: str) -> str:
    """What is allowed, in our words (``must be > 0``) rather than pydantic's."""
    bounds = {
        "greater_than": ("gt", ">"),
        "greater_than_equal": ("ge", ">="),
        "less_than": ("lt", "<"),
        "less_than_equal": ("le", "<="),
    }
    if kind in bounds:
        name, op = bounds[kind]
        return f"must be {op} {ctx.get(name)}"
    if kind == "literal_error":
        return f"must be one of {ctx.get('expected')}"
    if kind == "too_short":
        return f"must have at least {ctx.get('min_length')} item(s)"
    if kind == "too_long":
        return f"must have at most {ctx.get('max_length')} item(s)"
    if kind == "string_too_long":
        return f"must be at most {ctx.get('max_length')} characters long"
    if kind == "string_too_short":
        return f"must be at least {ctx.get('min_length')} character(s) long"
    if kind == "string_pattern_mismatch":
        return f"must match the pattern {ctx.get('pattern')}"
    plain = {
        "float_type": "must be a number",
        "float_parsing": "must be a number",
        "int_type": "must be a whole number",
        "int_parsing": "must be a whole number",
        "int_from_float": "must be a whole number",
        "bool_type": "must be true or false",
        "string_type": "must be a string (in quotes)",
        "list_type": "must be a list [ ... ]",
        "dict_type": "must be a table",
        "model_type": "must be a table",
        "model_attributes_type": "must be a table",
        "finite_number": "must be a finite number (not inf or nan)",
    }
    return plain.get(kind, msg)


def _is_table(value: Any) -> bool:
    """A table or a list of tables (printed as the key only, not dumped)."""
    return isinstance(value, dict) or (
        isinstance(value, list) and any(isinstance(v, dict) for v in value)
    )


def _join_key(table: str, key: str) -> str:
    """``fluid`` + ``blocks[0].upper`` -> ``fluid.blocks[0].upper``."""
    if table == "(top level)":
        return key
    return table + key if key.startswith("[") else f"{table}.{key}"


def validate(data: dict, source: str | None = None) -> Scenario:
    """Validate a scenario dictionary, raising :class:`ScenarioError` with all problems."""
    try:
        return Scenario.model_validate(data)
    except ValidationError as err:
        raise ScenarioError(format_validation_error(err), source) from None


#: a scenario file is a few kB; a larger one is refused before it is read
MAX_SCENARIO_BYTES = 4 * 1024 * 1024
#: tables and arrays nested deeper than this are refused (the schema nests about 6 deep)
MAX_NESTING = 32


def decode_scenario_bytes(raw: bytes, source: str | None = None) -> str:
    """``raw`` as UTF-8 text; a byte that is no UTF-8 is reported with its line and column."""
    try:
        return raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = raw.count(b"\n", 0, exc.start) + 1
        column = exc.start - (raw.rfind(b"\n", 0, exc.start) + 1) + 1
        bad = raw[exc.start : exc.start + 1]
        raise ScenarioError(
            [
                f"byte {bad!r} at line {line}, column {column} is not UTF-8: a scenario file "
                "must be UTF-8 text (TOML)"
            ],
            source,
        ) from None


def load_scenario(path: str | Path, overrides: Sequence[str] = ()) -> LoadedScenario:
    """Read, override and validate the scenario at ``path``."""
    path = Path(path)
    if not path.is_file():
        raise ScenarioError([f"scenario file {str(path)!r} does not exist"])
    try:
        size = path.stat().st_size
        if size > MAX_SCENARIO_BYTES:
            raise ScenarioError(
                [
                    f"scenario file {str(path)!r} is {size} bytes; a scenario file may have at "
                    f"most {MAX_SCENARIO_BYTES} bytes"
                ]
            )
        with path.open("rb") as f:
            raw = f.read(MAX_SCENARIO_BYTES + 1)
    except OSError as exc:
        raise ScenarioError([f"scenario file {str(path)!r} cannot be read: {exc}"]) from None
    text = decode_scenario_bytes(raw, str(path))
    return load_scenario_text(text, overrides, path)


def _too_deep(data: Any, limit: int = MAX_NESTING) -> str | None:
    """The dotted key of the first value nested deeper than ``limit``, or None (iterative)."""
    stack: list[tuple[Any, list[str | int]]] = [(data, [])]
    while stack:
        node, loc = stack.pop()
        if len(loc) > limit:
            return _dotted(loc[: limit + 1])
        if isinstance(node, dict):
            stack.extend((v, [*loc, str(k)]) for k, v in node.items())
        elif isinstance(node, list):
            stack.extend((v, [*loc, i]) for i, v in enumerate(node))
    return None


def _parse_toml(text: str, src: str | None) -> dict:
    """``tomllib.loads`` with its errors (deep nesting included) as :class:`ScenarioError`."""
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ScenarioError([f"not valid TOML: {exc}"], src) from None
    except RecursionError:
        raise ScenarioError(
            [f"tables or arrays nested too deep; at most {MAX_NESTING} levels are allowed"], src
        ) from None


def load_scenario_text(
    text: str, overrides: Sequence[str] = (), path: Path | None = None
) -> LoadedScenario:
    """Validate scenario TOML ``text`` with ``overrides`` applied."""
    src = str(path) if path else None
    if len(text) > MAX_SCENARIO_BYTES:
        raise ScenarioError(
            [f"scenario text has {len(text)} characters; at most {MAX_SCENARIO_BYTES} allowed"],
            src,
        )
    data = _parse_toml(text, src)
    for item in overrides:
        key, value = parse_override(item, bare_words=True)
        apply_override(data, key, value)
    deep = _too_deep(data)
    if deep is not None:
        raise ScenarioError(
            [f"{deep}: nested more than {MAX_NESTING} levels deep; at most {MAX_NESTING} allowed"],
            src,
        )
    scenario = validate(data, src)
    return LoadedScenario(scenario=scenario, text=text, overrides=list(overrides), path=path)
