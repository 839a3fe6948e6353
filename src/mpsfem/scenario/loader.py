"""Read a scenario TOML file, apply ``--set key=value`` overrides and validate it.

Every problem is reported before any compute starts, as ``<dotted key> = <value given>: <what is
allowed>``; unknown keys list the keys that are allowed at that place.
"""

from __future__ import annotations

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
            lines.append(f"{key}: unknown key; allowed here: {', '.join(allowed)}")
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
        msg = msg.removeprefix("Value error, ")
        if _is_table(given):
            lines.append(f"{key}: {msg}")  # a whole table's check: no dump of the table
        else:
            lines.append(f"{key} = {given!r}: {msg}")
    return lines


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


def load_scenario(path: str | Path, overrides: Sequence[str] = ()) -> LoadedScenario:
    """Read, override and validate the scenario at ``path``."""
    path = Path(path)
    if not path.is_file():
        raise ScenarioError([f"scenario file {str(path)!r} does not exist"])
    text = path.read_text(encoding="utf-8")
    return load_scenario_text(text, overrides, path)


def load_scenario_text(
    text: str, overrides: Sequence[str] = (), path: Path | None = None
) -> LoadedScenario:
    """Validate scenario TOML ``text`` with ``overrides`` applied."""
    src = str(path) if path else None
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ScenarioError([f"not valid TOML: {exc}"], src) from None
    for item in overrides:
        key, value = parse_override(item, bare_words=True)
        apply_override(data, key, value)
    scenario = validate(data, src)
    return LoadedScenario(scenario=scenario, text=text, overrides=list(overrides), path=path)
