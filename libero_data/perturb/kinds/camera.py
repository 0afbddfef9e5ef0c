"""``camera``: the agentview camera turned about the point its optical axis meets the table (or
floor), by azimuth and elevation, moved closer or further, and its field of view changed."""

from __future__ import annotations

from typing import Any, ClassVar

import numpy as np

from libero_data.perturb.kinds.base import Drawn, Kind, register, rotation, sign

CAMERA = "agentview"


@register
class Camera(Kind):
    order = 4
    summary = "agentview azimuth and elevation about the scene, distance to it, field of view"
    magnitudes: ClassVar[dict[str, tuple[Any, ...]]] = {
        "azimuth_deg": (5.0, 10.0, 15.0, 22.5, 30.0),
        "elevation_deg": (2.5, 5.0, 7.5, 10.0, 12.5),
        "distance_change": (0.05, 0.10, 0.15, 0.20, 0.25),
        "fovy_change_deg": (2.0, 4.0, 6.0, 8.0, 10.0),
    }

    def sample(self, m: dict[str, Any], rng: np.random.Generator) -> dict[str, Any]:
        return {
            "azimuth_deg": sign(rng) * m["azimuth_deg"],
            "elevation_deg": sign(rng) * m["elevation_deg"],
            "distance_scale": 1.0 + sign(rng) * m["distance_change"],
            "fovy_change_deg": sign(rng) * m["fovy_change_deg"],
        }

    def apply_scene(self, raw: Any, p: Drawn) -> None:
        _move_camera(raw.sim.model._model, raw.sim.data._data, p.params)


def surface_height(model: Any, data: Any) -> float:
    """Height of the table top (or of the floor in floor scenes) the objects stand on."""
    import mujoco

    table = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, "table_visual")
    if table >= 0:
        return float(data.geom_xpos[table][2] + model.geom_size[table][2])
    floor = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, "floor")
    return float(data.geom_xpos[floor][2]) if floor >= 0 else 0.0


def _move_camera(model: Any, data: Any, params: dict[str, Any]) -> None:
    import mujoco

    cam = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_CAMERA, CAMERA)
    pos = np.array(model.cam_pos[cam], dtype=np.float64)
    flat = np.zeros(9)
    mujoco.mju_quat2Mat(flat, np.array(model.cam_quat[cam], dtype=np.float64))
    rot = flat.reshape(3, 3)
    forward = -rot[:, 2]  # cameras look along their -z axis
    height = surface_height(model, data)
    t = (height - pos[2]) / forward[2] if forward[2] < -1e-6 else 1.0
    pivot = pos + max(t, 0.1) * forward
    offset = pos - pivot
    turn = rotation(np.array([0.0, 0.0, 1.0]), float(params["azimuth_deg"]))
    offset = turn @ offset
    tilt_axis = np.cross(offset, [0.0, 0.0, 1.0])
    tilt = (
        rotation(tilt_axis, float(params["elevation_deg"])) if np.linalg.norm(tilt_axis) > 1e-9 else np.eye(3)
    )
    moved = tilt @ turn
    model.cam_pos[cam] = pivot + float(params["distance_scale"]) * (tilt @ offset)
    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, (moved @ rot).reshape(-1))
    model.cam_quat[cam] = quat
    model.cam_fovy[cam] = float(np.clip(model.cam_fovy[cam] + float(params["fovy_change_deg"]), 10.0, 120.0))
    mujoco.mj_kinematics(model, data)
    mujoco.mj_camlight(model, data)
