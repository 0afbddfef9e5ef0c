"""The one base of every config: a frozen dataclass, validated on construction, saved as JSON.

Subclasses validate in ``__post_init__`` with the ``_check_*`` helpers (or ``_fail``), which
raise :class:`~libero_data.errors.ConfigError` naming the class, the field and the value. A
class with a non-empty ``name`` class variable (a registry name, not a field) writes it as
``type`` in :meth:`Config.to_dict`; it picks the registry entry on the way back. Tuples become lists in JSON and lists become
tuples again in :meth:`Config.from_dict`. No heavy imports here: configs are built, checked and
saved cheaply.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any, ClassVar, Self

from libero_data.errors import ConfigError, InputError


@dataclass(frozen=True)
class Config:
    """Base of the project's configs (see the module docstring)."""

    #: What a file written before a field existed meant by leaving it out (field -> value): the
    #: one way configs read what earlier versions wrote (:meth:`upgrade`, used by :meth:`from_dict`).
    legacy: ClassVar[dict[str, Any]] = {}

    @classmethod
    def upgrade(cls, data: Mapping[str, Any]) -> dict[str, Any]:
        """``data`` as any version wrote it, with the fields it predates filled from :attr:`legacy`."""
        return {**cls.legacy, **data}

    # -- validation ------------------------------------------------------------------------------
    def _fail(self, field: str, message: str) -> None:
        raise ConfigError(
            f"{type(self).__name__}.{field} {message}, got {getattr(self, field)!r}", field=field
        )

    def _check_positive(self, *fields: str) -> None:
        for field in fields:
            value = getattr(self, field)
            if isinstance(value, bool) or not isinstance(value, int) or value <= 0:
                self._fail(field, "must be a positive integer")

    def _check_non_negative(self, *fields: str) -> None:
        for field in fields:
            value = getattr(self, field)
            if isinstance(value, bool) or not isinstance(value, int) or value < 0:
                self._fail(field, "must be a non-negative integer")

    def _check_probability(self, *fields: str) -> None:
        for field in fields:
            value = getattr(self, field)
            if isinstance(value, bool) or not isinstance(value, int | float) or not 0.0 <= value < 1.0:
                self._fail(field, "must be a probability in [0, 1)")

    def _check_choice(self, field: str, choices: tuple[str, ...]) -> None:
        if getattr(self, field) not in choices:
            self._fail(field, "must be " + " or ".join(repr(c) for c in choices))

    # -- serialisation ---------------------------------------------------------------------------
    @classmethod
    def registry_name(cls) -> str:
        """The registry entry this config belongs to ("" where ``name`` is a field or unset)."""
        if any(f.name == "name" for f in dataclasses.fields(cls)):
            return ""
        return str(getattr(cls, "name", ""))

    def to_dict(self) -> dict[str, Any]:
        """JSON-serialisable; ``type`` first where the class has a registry name."""
        kind = self.registry_name()
        data: dict[str, Any] = {"type": kind} if kind else {}
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            data[f.name] = list(value) if isinstance(value, tuple) else value
        return data

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> Self:
        """Inverse of :meth:`to_dict` (a ``type``, if present, must be this class's); what an
        earlier version wrote is read through :meth:`upgrade`."""
        data = cls.upgrade(data)
        expected = cls.registry_name()
        kind = data.pop("type", expected) if expected else expected
        if kind != expected:
            raise ConfigError(f"config type {kind!r} does not match {cls.__name__} ({expected!r})")
        known = {f.name for f in dataclasses.fields(cls)}
        unknown = sorted(set(data) - known)
        if unknown:
            raise ConfigError(f"{cls.__name__} has no field(s) {', '.join(unknown)}", field=unknown[0])
        return cls(**{k: tuple(v) if isinstance(v, list) else v for k, v in data.items()})

    def replace(self, **changes: Any) -> Self:
        """A copy with some fields changed (validated again)."""
        return dataclasses.replace(self, **changes)

    def with_assignments(
        self, assignments: Sequence[str], *, what: str, field: str, fixed: tuple[str, ...] = ()
    ) -> Self:
        """A copy with ``name=value`` assignments applied, values read as JSON, else as text (a
        command line's ``--set``); ``what`` names the config in the one sentence a bad one gets,
        ``field`` the option, and ``fixed`` fields may not be set."""
        import json

        fields = {f.name for f in dataclasses.fields(self)} - set(fixed)
        changes: dict[str, Any] = {}
        for item in assignments:
            name, sep, raw = item.partition("=")
            name = name.strip()
            if not sep or not name:
                raise InputError(f"a {what} setting takes field=value, got {item!r}", field=field)
            if name not in fields:
                raise InputError(
                    f"the {what} has no field {name!r}; fields: {', '.join(sorted(fields))}", field=field
                )
            try:
                value = json.loads(raw)
            except json.JSONDecodeError:
                value = raw
            changes[name] = tuple(value) if isinstance(value, list) else value
        return self.replace(**changes) if changes else self
