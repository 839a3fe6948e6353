"""Base class of every scenario section and the error type of scenario validation.

Every section of a scenario file is a :class:`Section`: unknown keys are rejected, types are
checked strictly (an integer is accepted where a float is expected, nothing else is coerced),
every float must be finite (``inf`` and ``nan``, which TOML and ``--set`` accept, are refused), and
values are re-validated when assigned, so ``--set`` overrides go through the same checks.
"""

from __future__ import annotations

from pydantic import BaseModel, ConfigDict


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
