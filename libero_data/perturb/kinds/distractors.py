"""``distractors``: as many objects the task is not about as the level says (as many as fit), of
kinds LIBERO shows in such scenes."""

from __future__ import annotations

import dataclasses
from typing import Any, ClassVar

import numpy as np

from libero_data.bddl.model import Atom, Entity, Problem
from libero_data.perturb.kinds.base import Kind, VariantSource, register
from libero_data.perturb.kinds.placement import centre, free_centre, square, table_starts_all
from libero_data.scenes.sampler import SamplingError


@register
class Distractors(Kind):
    order = 1
    rewrites_task = True
    needs_layout = True
    keeps_layout = False
    summary = "how many objects the task is not about are added (as many as fit)"
    magnitudes: ClassVar[dict[str, tuple[Any, ...]]] = {"count": (1, 2, 3, 4, 5)}

    def vary(self, src: VariantSource, rng: np.random.Generator) -> Problem:
        """As many objects as the level says added where they fit, of kinds LIBERO shows in such scenes."""
        assert src.scene is not None and src.catalogue is not None
        scene, catalogue = src.scene, src.catalogue
        source, table = src.problem, scene.table
        present = set(src.category.values())
        seen = catalogue.seen_in.get(scene.kind, {})
        pool = [
            c
            for c, spec in sorted(catalogue.objects.items())
            if c not in present and spec.graspable and spec.radius <= 0.07 and c in seen
        ]
        k = int(self.magnitudes["count"][src.level - 1])
        chosen = [pool[int(i)] for i in rng.choice(len(pool), size=min(k, len(pool)), replace=False)]
        radius = src.radius
        taken = [(*centre(r), radius[n]) for n, r in table_starts_all(source, table).items()]
        regions, objects, init = list(source.regions), list(source.objects), list(source.init)
        for extra in chosen:
            spot = free_centre(rng, scene, catalogue.objects[extra].radius, taken)
            if spot is None:
                continue
            name = f"{extra}_1"
            region = f"{extra}_init_region"
            regions.append(square(region, table, *spot))
            objects.append(Entity(name, extra))
            init.append(Atom("On", (name, f"{table}_{region}")))
            taken.append((*spot, catalogue.objects[extra].radius))
        if len(objects) == len(source.objects):
            raise SamplingError(f"{src.task_id}: no room for a distractor")
        return dataclasses.replace(source, regions=tuple(regions), objects=tuple(objects), init=tuple(init))
