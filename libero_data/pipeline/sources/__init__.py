"""Demonstration sources (:mod:`~libero_data.pipeline.sources.base` says what one is): every
module of this package registers one, found when first asked for."""

from __future__ import annotations

import functools
import importlib
import pkgutil

from libero_data.errors import InputError
from libero_data.pipeline.request import GenerateRequest
from libero_data.pipeline.sources.base import (
    DEMO_SOURCES,
    CardPart,
    DemoSource,
    EpisodeRecord,
    register_source,
)


@functools.cache
def _load_modules() -> None:
    for module in pkgutil.iter_modules(__path__):
        if module.name != "base":
            importlib.import_module(f"{__name__}.{module.name}")


def demo_sources() -> tuple[DemoSource, ...]:
    """Every registered source (these modules' and any registered since), in the order asked."""
    _load_modules()
    return tuple(sorted((DEMO_SOURCES.get(n) for n in DEMO_SOURCES.names()), key=lambda s: s.order))


def source_of(request: GenerateRequest) -> DemoSource:
    """The source that makes ``request``'s episodes: the first, in order, that claims it."""
    for source in demo_sources():
        if source.claims(request):
            return source
    names = ", ".join(s.name for s in demo_sources())
    raise InputError(f"no demonstration source makes this request ({names})", field="source")


__all__ = ["CardPart", "DemoSource", "EpisodeRecord", "demo_sources", "register_source", "source_of"]
