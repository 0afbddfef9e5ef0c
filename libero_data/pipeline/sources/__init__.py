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


def source_names() -> list[str]:
    """The registered sources' names, in the order they are asked (``--source``'s choices)."""
    return [s.name for s in demo_sources()]


def named_source(name: str) -> DemoSource:
    """The source registered as ``name`` (one sentence naming the known ones otherwise)."""
    _load_modules()
    if name not in DEMO_SOURCES:
        raise InputError(
            f"unknown demonstration source {name!r}; choose among {', '.join(source_names())}", field="source"
        )
    return DEMO_SOURCES.get(name)


def source_choices() -> str:
    """The registered sources as ``--source`` lists them: each with what a request for it needs
    (the sources that need nothing are those ``generate`` alone can run)."""
    return "; ".join(
        f"{s.name}, only with {s.needs}" if s.needs else s.name
        for s in sorted(demo_sources(), key=lambda s: bool(s.needs))
    )


def source_of(request: GenerateRequest) -> DemoSource:
    """The source that makes ``request``'s episodes: the one it names (``request.source``), else
    the first, in order, that claims it. A re-render (``request.rerender_of``) is made from the
    stored states whatever source made them; that source writes the card's account of them."""
    if request.source and not request.rerender_of:
        source = named_source(request.source)
        if not source.claims(request):
            needs = f": it needs {source.needs}" if source.needs else ""
            raise InputError(
                f"the demonstration source {source.name!r} cannot make this request{needs}", field="source"
            )
        return source
    for source in demo_sources():
        if source.claims(request):
            return source
    names = ", ".join(source_names())
    raise InputError(f"no demonstration source makes this request ({names})", field="source")


__all__ = [
    "CardPart",
    "DemoSource",
    "EpisodeRecord",
    "demo_sources",
    "named_source",
    "register_source",
    "source_choices",
    "source_names",
    "source_of",
]
