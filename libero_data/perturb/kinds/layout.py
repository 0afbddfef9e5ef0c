"""``layout``: the movable objects start in new places (the scene's object rectangles, at least
the level's distance away from where the source task puts them)."""

from __future__ import annotations

from typing import Any, ClassVar

import numpy as np

from libero_data.bddl.model import Problem
from libero_data.perturb.kinds.base import Kind, VariantSource, register
from libero_data.perturb.kinds.placement import (
    centre,
    free_centre,
    replace_starts,
    table_starts,
    table_starts_all,
)
from libero_data.scenes.sampler import SamplingError


@register
class Layout(Kind):
    order = 0
    rewrites_task = True
    needs_layout = True
    keeps_layout = False
    summary = "the least distance each movable object is moved from its source place"
    magnitudes: ClassVar[dict[str, tuple[Any, ...]]] = {"min_move_m": (0.06, 0.09, 0.12, 0.15, 0.18)}

    def vary(self, src: VariantSource, rng: np.random.Generator) -> Problem:
        """The objects that start on the table moved to new places, clear of their old ones."""
        assert src.scene is not None
        scene = src.scene
        source, table, radius = src.problem, scene.table, src.radius
        starts = table_starts(source, table)
        if not starts:
            raise SamplingError(f"{src.task_id}: no object starts on the table")
        fixed = [
            (*centre(r), radius[n]) for n, r in table_starts_all(source, table).items() if n not in starts
        ]
        taken = list(fixed)
        new: dict[str, tuple[float, float]] = {}
        moved = float(self.magnitudes["min_move_m"][src.level - 1])
        for name in sorted(starts, key=lambda n: -radius[n]):
            c = free_centre(rng, scene, radius[name], taken, avoid=centre(starts[name]), moved=moved)
            if c is None:
                raise SamplingError(f"{src.task_id}: no new place for {name}")
            new[name] = c
            taken.append((*c, radius[name]))
        return replace_starts(source, table, new)
