"""Shared by the kinds that place objects (layout, distractors): the task's scene layout, where
its objects start on the table, and free places there."""

from __future__ import annotations

import dataclasses

import numpy as np

from libero_data.bddl.model import Atom, Problem, Region, atoms
from libero_data.scenes.catalogue import Catalogue, SceneSpec
from libero_data.scenes.sampler import GAP, HALF_WIDTH

FIXTURE_CLEARANCE = 0.2  # metres from a fixture's centre to any new object's footprint
MOVED = 0.06  # metres between a moved object's new centre and its source region's centre (level 1)


def scene_of(task_id: str, catalogue: Catalogue) -> SceneSpec | None:
    for scene in catalogue.scenes.values():
        if task_id in scene.sources:
            return scene
    return None


def table_starts(problem: Problem, table: str) -> dict[str, Region]:
    """Movable objects that start on the table, with their init region (not used by the goal)."""
    goal_names = {a for atom in atoms(problem.goal) for a in atom.args}
    objects = {o.name for o in problem.objects}
    out = {}
    for atom in problem.init:
        if atom.predicate == "On" and atom.args[0] in objects and atom.args[1].startswith(table + "_"):
            region = problem.region(atom.args[1])
            if atom.args[1] not in goal_names and region.ranges:
                out[atom.args[0]] = region
    return out


def centre(region: Region) -> tuple[float, float]:
    x0, y0, x1, y1 = region.ranges[0]
    return (x0 + x1) / 2, (y0 + y1) / 2


def square(name: str, table: str, x: float, y: float) -> Region:
    box = (
        round(x - HALF_WIDTH, 4),
        round(y - HALF_WIDTH, 4),
        round(x + HALF_WIDTH, 4),
        round(y + HALF_WIDTH, 4),
    )
    return Region(name, table, (box,), (0.0, 0.0))


def replace_starts(problem: Problem, table: str, new: dict[str, tuple[float, float]]) -> Problem:
    """Give each object in ``new`` its own init square at the given centre."""
    regions = list(problem.regions)
    init = []
    for atom in problem.init:
        if atom.predicate == "On" and atom.args[0] in new:
            name = f"{atom.args[0]}_variant_init_region"
            regions.append(square(name, table, *new[atom.args[0]]))
            init.append(Atom("On", (atom.args[0], f"{table}_{name}")))
        else:
            init.append(atom)
    used = {a for atom in [*init, *atoms(problem.goal)] for a in atom.args}
    regions = [r for r in regions if r.target != table or r.full_name in used]
    return dataclasses.replace(problem, regions=tuple(regions), init=tuple(init))


def free_centre(
    rng: np.random.Generator,
    scene: SceneSpec,
    radius: float,
    taken: list[tuple[float, float, float]],
    avoid: tuple[float, float] | None = None,
    moved: float = MOVED,
) -> tuple[float, float] | None:
    boxes = np.asarray(scene.boxes, dtype=float)
    # The table area LIBERO uses for objects in this layout, kept clear of the fixtures.
    lo, hi = boxes[:, :2].min(0) - 0.03, boxes[:, 2:].max(0) + 0.03
    fixtures = [((f.ranges[0] + f.ranges[2]) / 2, (f.ranges[1] + f.ranges[3]) / 2) for f in scene.fixtures]
    for _ in range(500):
        c = (float(rng.uniform(lo[0], hi[0])), float(rng.uniform(lo[1], hi[1])))
        if any(np.hypot(c[0] - fx, c[1] - fy) < FIXTURE_CLEARANCE + radius for fx, fy in fixtures):
            continue
        if avoid is not None and np.hypot(c[0] - avoid[0], c[1] - avoid[1]) < moved:
            continue
        if all(np.hypot(c[0] - x, c[1] - y) >= radius + r + GAP + 2 * HALF_WIDTH for x, y, r in taken):
            return c
    return None


def table_starts_all(problem: Problem, table: str) -> dict[str, Region]:
    objects = {o.name for o in problem.objects}
    out = {}
    for atom in problem.init:
        if atom.predicate == "On" and atom.args[0] in objects and atom.args[1].startswith(table + "_"):
            region = problem.region(atom.args[1])
            if region.ranges:
                out[atom.args[0]] = region
    return out
