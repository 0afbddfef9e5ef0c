"""A libero-data dataset's stored states as a demonstration source (``libero-data rerender``):
its episodes, the records of the new dataset's slots, are written before ``generate`` starts
(:mod:`~libero_data.pipeline.rerender`); the card says what the source dataset's demonstrations
were (the source that made them) and where they were re-rendered from."""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING, Any

from libero_data.pipeline.sources.base import CardPart, DemoSource, register_source

if TYPE_CHECKING:
    from libero_data.pipeline.request import GenerateRequest


class StoredStates(DemoSource):
    """Another dataset's episodes: claims a request re-rendered from a dataset, asked first
    (the source dataset's request, which it carries, names the source that made its episodes)."""

    order = 0

    needs = "a dataset to re-render (libero-data rerender makes the request)"

    def claims(self, request: GenerateRequest) -> bool:
        return bool(request.rerender_of)

    def card(self, request: GenerateRequest, suite: str, infos: list[dict[str, Any]]) -> CardPart:
        from libero_data.pipeline.sources import source_of

        made = source_of(request.replace(rerender_of="")).card(request, suite, infos)
        summary = f"{made.summary} Re-rendered from the stored states of `{request.rerender_of}`."
        return dataclasses.replace(made, summary=summary)


register_source(StoredStates("stored_states"))
