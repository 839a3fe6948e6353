"""Name -> component registries (mapping, acceleration, transport, coupling scheme).

A registry maps a name used in the scenario to ``"module:attribute"``; the module is imported
only when the component is asked for, so e.g. ``mpi4py`` and ``zenoh`` load only in runs that use
them. Adding a component is one new module plus one line in its registry.
"""

from __future__ import annotations

import importlib
from collections.abc import Iterator
from typing import Any


class Registry:
    """Components of one kind, chosen by name.

    >>> r = Registry("acceleration", {"constant": "mpsfem.coupler.acceleration.constant:Constant"})
    >>> r.names()
    ('constant',)
    """

    def __init__(self, kind: str, entries: dict[str, str]) -> None:
        self.kind = kind
        self._entries = dict(entries)

    def names(self) -> tuple[str, ...]:
        """Registered names, in registration order."""
        return tuple(self._entries)

    def __contains__(self, name: object) -> bool:
        return name in self._entries

    def __iter__(self) -> Iterator[str]:
        return iter(self._entries)

    def get(self, name: str) -> Any:
        """The registered class (or factory) called ``name``; KeyError names the allowed ones."""
        try:
            target = self._entries[name]
        except KeyError:
            allowed = ", ".join(repr(n) for n in self._entries)
            raise KeyError(f"unknown {self.kind} {name!r}; allowed: {allowed}") from None
        module, _, attr = target.partition(":")
        return getattr(importlib.import_module(module), attr)

    def create(self, name: str, *args: Any, **kwargs: Any) -> Any:
        """Instantiate component ``name`` with the given arguments."""
        return self.get(name)(*args, **kwargs)
