"""The robustness kinds, one module each (:mod:`~libero_data.perturb.kinds.base` says what a kind
is): every module of this package that registers a kind is one, found when first asked for."""

from __future__ import annotations

import functools
import importlib
import pkgutil

from libero_data.perturb.kinds.base import REGISTRY, Kind

#: modules here that hold no kind
SHARED = ("base", "placement")


@functools.cache
def _loaded() -> tuple[Kind, ...]:
    for module in pkgutil.iter_modules(__path__):
        if module.name not in SHARED:
            importlib.import_module(f"{__name__}.{module.name}")
    return tuple(sorted((REGISTRY.get(name) for name in REGISTRY.names()), key=lambda k: k.order))


def all_kinds() -> tuple[Kind, ...]:
    """Every kind, in order."""
    return _loaded()


def get_kind(name: str) -> Kind:
    """The kind called ``name`` (an UnknownNameError naming the known ones otherwise)."""
    _loaded()
    return REGISTRY.get(name)


__all__ = ["Kind", "all_kinds", "get_kind"]
