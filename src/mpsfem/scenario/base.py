"""Base class of every scenario section and the error type of scenario validation.

Every section of a scenario file is a :class:`Section`: unknown keys are rejected, types are
checked strictly (an integer is accepted where a float is expected, nothing else is coerced),
every float must be finite (``inf`` and ``nan``, which TOML and ``--set`` accept, are refused), and
values are re-validated when assigned, so ``--set`` overrides go through the same checks.
"""

from __future__ import annotations

from typing import Annotated, Any

from pydantic import BaseModel, ConfigDict, Field

#: every coordinate of a scene, m, lies within +-this (a wider scene is no particle scene; wider
#: values overflowed the lattice arithmetic)
COORDINATE_LIMIT = 1e6

#: a coordinate, m
Coordinate = Annotated[float, Field(ge=-COORDINATE_LIMIT, le=COORDINATE_LIMIT)]
#: a point of the scene, m
Point = list[Coordinate]


class Section(BaseModel):
    """A table of the scenario TOML file (strict, closed to unknown keys)."""

    model_config = ConfigDict(
        extra="forbid",
        strict=True,
        allow_inf_nan=False,
        validate_assignment=True,
        validate_default=True,
        use_attribute_docstrings=True,
    )


class ScenarioError(ValueError):
    """Invalid scenario input; ``problems`` lists one line per offending key.

    Each line names the dotted key, the value given and what is allowed, e.g.
    ``fluid.spacing = -0.1: must be > 0``.
    """

    def __init__(self, problems: list[str], source: str | None = None) -> None:
        self.problems = list(problems)
        self.source = source
        head = f"invalid scenario{f' {source}' if source else ''}"
        super().__init__(head + ":\n  " + "\n  ".join(self.problems))


_NO_VALUE: Any = object()


class InvalidValue(ValueError):
    """A table-level (cross-key) check failed at ``key`` inside the table being validated.

    ``key`` is relative to that table (``blocks[0].upper``, ``bc``); the scenario loader prefixes
    the table's own dotted path, so the message names the full key, the value given (left out
    where there is none, e.g. a missing key) and what is allowed."""

    def __init__(self, key: str, message: str, value: Any = _NO_VALUE) -> None:
        self.key = key
        self.message = message
        self.value = value
        super().__init__(f"{key} = {value!r}: {message}" if self.has_value else f"{key}: {message}")

    @property
    def has_value(self) -> bool:
        return self.value is not _NO_VALUE
