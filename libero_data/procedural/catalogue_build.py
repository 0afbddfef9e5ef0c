"""Building ``catalogue.json`` (:mod:`libero_data.scenes.catalogue`) from the shipped tasks:
their BDDL files mined for layouts, the assets' footprints measured in the simulator. Run once
(``python -m libero_data.procedural.catalogue_build``); the output is committed."""

from __future__ import annotations

import json
from typing import Any

from libero_data.scenes.catalogue import CATALOGUE_PATH, NOT_GRASPABLE, SCENE_KINDS


def build_catalogue() -> dict[str, Any]:
    """Mine the shipped suites' BDDL files and measure the assets' footprints."""
    from libero_data.tasks import get_suite

    tasks = [
        t
        for s in ("libero_spatial", "libero_object", "libero_goal", "libero_10", "libero_90")
        for t in get_suite(s).tasks
    ]
    doors, knobs, moved = _operated_categories(tasks)
    layouts, object_regions, seen_in = _layouts(tasks)
    scenes = _scenes(layouts, doors, knobs)
    footprints = _measure_footprints(tasks)
    object_specs: dict[str, Any] = {
        category: {
            "radius": round(footprints[category][0], 4),
            "height": round(footprints[category][1], 4),
            "graspable": category in moved and category not in NOT_GRASPABLE,
            "regions": sorted(object_regions.get(category, ())),
        }
        for category in sorted(footprints)
    }
    return {"scenes": scenes, "objects": object_specs, "seen_in": seen_in}


def _operated_categories(tasks: list[Any]) -> tuple[set[str], set[str], set[str]]:
    """Fixture categories whose doors the shipped tasks open or close, those with knobs they
    turn, and the object categories they move."""
    from libero_data.bddl.model import atoms

    doors: set[str] = set()
    knobs: set[str] = set()
    moved: set[str] = set()
    for task in tasks:
        p = task.problem
        for atom in list(atoms(p.goal)) + list(p.init):
            if atom.predicate in ("Open", "Close"):
                arg = atom.args[0]
                for f in p.fixtures:
                    if arg == f.name:
                        doors.add(f.category)
            if atom.predicate in ("Turnon", "Turnoff"):
                knobs.add(p.category_of(atom.args[0]))
        for atom in atoms(p.goal):
            if atom.predicate in ("On", "In") and atom.args[0] in {o.name for o in p.objects}:
                moved.add(p.category_of(atom.args[0]))
    return doors, knobs, moved


def _layouts(
    tasks: list[Any],
) -> tuple[dict[tuple[Any, ...], dict[str, Any]], dict[str, set[str]], dict[str, dict[str, list[str]]]]:
    """The distinct scene layouts of the shipped tasks (fixtures where they stand, the spots
    objects start on), the regions each object category carries, and where each was seen."""
    layouts: dict[tuple[Any, ...], dict[str, Any]] = {}
    object_regions: dict[str, set[str]] = {}
    seen_in: dict[str, dict[str, list[str]]] = {}
    for task in tasks:
        p = task.problem
        table = next(f for f in p.fixtures if f.category in _TABLES)
        fixture_regions = _fixture_regions(p, table)
        entry = _layout_entry(layouts, p, table, fixture_regions)
        entry["sources"].append(task.id)
        for name, (category, init, carried) in fixture_regions.items():
            _add_fixture(entry, p, name, category, init, carried)
        objects = {o.name: o.category for o in p.objects}
        kind = SCENE_KINDS[p.problem]
        for o in p.objects:
            seen_in.setdefault(kind, {}).setdefault(o.category, []).append(task.id)
        for r in p.regions:
            if r.target in objects:
                object_regions.setdefault(objects[r.target], set()).add(r.name)
        for atom in p.init:
            if (
                atom.predicate == "On"
                and atom.args[0] in objects
                and atom.args[1].startswith(table.name + "_")
            ):
                region = p.region(atom.args[1])
                for box in region.ranges:
                    entry["boxes"].add(tuple(round(v, 4) for v in box))
    return layouts, object_regions, seen_in


def _fixture_regions(p: Any, table: Any) -> dict[str, tuple[str, Any, list[str]]]:
    """Per fixture other than the table: its category, its placement region, the regions it carries."""
    fixture_regions = {}
    for f in p.fixtures:
        if f is table:
            continue
        init = next(
            (r for r in p.regions if r.target == table.name and r.name == f"{f.category}_init_region"),
            None,
        )
        if init is None:
            init = _region_of(p, f.name, table.name)
        carried = sorted(r.name for r in p.regions if r.target == f.name)
        fixture_regions[f.name] = (f.category, init, carried)
    return fixture_regions


def _layout_entry(
    layouts: dict[tuple[Any, ...], dict[str, Any]],
    p: Any,
    table: Any,
    fixture_regions: dict[str, tuple[str, Any, list[str]]],
) -> dict[str, Any]:
    """The layout a problem belongs to (its scene and where its fixtures stand), made on first sight."""
    import numpy as np

    key = (
        p.problem,
        tuple(
            sorted(
                (c, tuple(np.round(i.ranges[0], 2)) if i else None) for c, i, _ in fixture_regions.values()
            )
        ),
    )
    return layouts.setdefault(
        key,
        {
            "problem": p.problem,
            "table": table.name,
            "table_category": table.category,
            "fixtures": {},
            "boxes": set(),
            "sources": [],
        },
    )


def _add_fixture(
    entry: dict[str, Any], p: Any, name: str, category: str, init: Any, carried: list[str]
) -> None:
    """Record a fixture of a layout, with what this task does with its drawers and door."""
    from libero_data.bddl.model import atoms

    spec = entry["fixtures"].setdefault(
        name,
        {
            "name": name,
            "category": category,
            "ranges": list(init.ranges[0]) if init else None,
            "yaw": list(init.yaw_rotation) if init and init.yaw_rotation else None,
            "regions": set(),
            "operated": set(),
            "closed": set(),
            "door_ops": set(),
        },
    )
    spec["regions"].update(carried)
    # Drawers this layout's own tasks open or close (reachable ones, in this pose).
    for atom in [*atoms(p.goal), *p.init]:
        if atom.predicate in ("Open", "Close") and atom.args[0].startswith(name + "_"):
            spec["operated"].add(atom.args[0][len(name) + 1 :])
    for atom in atoms(p.goal):
        if atom.predicate == "Close" and atom.args[0].startswith(name + "_"):
            spec["closed"].add(atom.args[0][len(name) + 1 :])
        if atom.predicate in ("Open", "Close") and atom.args[0] == name:
            spec["door_ops"].add(atom.predicate)


def _scenes(
    layouts: dict[tuple[Any, ...], dict[str, Any]], doors: set[str], knobs: set[str]
) -> dict[str, Any]:
    """The layouts as the catalogue's scenes, named by kind and fixtures."""
    scenes: dict[str, Any] = {}
    counts: dict[str, int] = {}
    for entry in sorted(layouts.values(), key=lambda e: (SCENE_KINDS[e["problem"]], e["sources"][0])):
        kind = SCENE_KINDS[entry["problem"]]
        categories = sorted({f["category"] for f in entry["fixtures"].values()})
        base = "_".join([kind, *categories]) if categories else kind
        counts[base] = counts.get(base, 0) + 1
        scene_id = base if counts[base] == 1 else f"{base}_{counts[base]}"
        fixtures = []
        for f in entry["fixtures"].values():
            fixtures.append(
                {
                    "name": f["name"],
                    "category": f["category"],
                    "ranges": f["ranges"],
                    "yaw": f["yaw"],
                    "regions": sorted(f["regions"]),
                    "drawers": sorted(r for r in f["regions"] if r in f["operated"]),
                    "closable": sorted(r for r in f["regions"] if r in f["closed"]),
                    # what this layout's shipped tasks do with the door: "Open", "Close"
                    "door": sorted(f["door_ops"]) if f["category"] in doors else [],
                    "knob": f["category"] in knobs,
                }
            )
        scenes[scene_id] = {
            "kind": kind,
            "problem": entry["problem"],
            "table": entry["table"],
            "table_category": entry["table_category"],
            "fixtures": fixtures,
            "boxes": sorted(entry["boxes"]),
            "sources": entry["sources"],
        }
    return scenes


_TABLES = {
    "kitchen_table",
    "living_room_table",
    "study_table",
    "table",
    "floor",
    "main_table",
    "coffee_table",
}


def _region_of(p: Any, name: str, table: str) -> Any:
    """The table region a fixture is placed in, from the init predicates."""
    for atom in p.init:
        if atom.predicate == "On" and atom.args[0] == name and atom.args[1].startswith(table + "_"):
            return p.region(atom.args[1])
    return None


def _measure_footprints(tasks: list[Any]) -> dict[str, tuple[float, float]]:
    """(radius about the centre in the table plane, height) of every movable category."""
    import numpy as np

    from libero_data.experts.scene import SceneView
    from libero_data.sim import EnvConfig, LiberoEnv

    out: dict[str, tuple[float, float]] = {}
    for task in tasks:
        missing = {o.category for o in task.problem.objects} - set(out)
        if not missing:
            continue
        with LiberoEnv(task, EnvConfig(cameras=())) as env:
            env.reset(task.init_states()[0], seed=0, render=False, settle=20)
            scene = SceneView(env)
            for o in task.problem.objects:
                if o.category not in missing or o.category in out:
                    continue
                pts = scene.points(o.name)
                centre = (pts[:, :2].max(0) + pts[:, :2].min(0)) / 2
                radius = float(np.linalg.norm(pts[:, :2] - centre, axis=1).max())
                out[o.category] = (radius, float(np.ptp(pts[:, 2])))
    return out


def write_catalogue() -> None:
    data = build_catalogue()
    CATALOGUE_PATH.write_text(json.dumps(data, indent=1, sort_keys=True) + "\n")
    print(f"wrote {CATALOGUE_PATH}: {len(data['scenes'])} scenes, {len(data['objects'])} object categories")


if __name__ == "__main__":
    write_catalogue()
