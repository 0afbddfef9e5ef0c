"""Model sizes: one table of what each size changes, declared on each config.

``paper`` is a config's defaults (the LIBERO paper's settings); ``quick`` and ``smoke`` are what
a config class lists in ``sizes`` (fields that differ from the paper's). A size a class does not
list is its paper size. Presets name a size for the policy and one for the algorithm.
"""

from __future__ import annotations

from typing import Any, ClassVar, Self

from libero_data.errors import InputError

#: every size, from the largest
SIZES = ("paper", "quick", "smoke")


class Sized:
    """Mixin for configs with sizes: ``sizes`` maps a size to the fields it changes."""

    sizes: ClassVar[dict[str, dict[str, Any]]] = {}

    @classmethod
    def size(cls, size: str, **overrides: Any) -> Self:
        """The config at ``size`` (``paper``, ``quick`` or ``smoke``), with optional overrides."""
        if size not in SIZES:
            raise InputError(
                f"unknown size {size!r} for {cls.__name__}; known: {', '.join(SIZES)}", field="size"
            )
        return cls(**{**cls.sizes.get(size, {}), **overrides})

    @classmethod
    def paper(cls, **overrides: Any) -> Self:
        return cls.size("paper", **overrides)

    @classmethod
    def smoke(cls, **overrides: Any) -> Self:
        return cls.size("smoke", **overrides)
