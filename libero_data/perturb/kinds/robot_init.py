"""``robot_init``: the arm's joints offset at every reset, by values drawn from the perturbation's
seed and the reset's seed (halved until the arm touches nothing); the expert starts from there."""

from __future__ import annotations

from typing import Any, ClassVar

import numpy as np

from libero_data.perturb.kinds.base import Drawn, Kind, register


@register
class RobotInit(Kind):
    order = 5
    summary = "the largest offset of each arm joint from the start configuration"
    magnitudes: ClassVar[dict[str, tuple[Any, ...]]] = {"joint_offset_rad": (0.05, 0.10, 0.15, 0.20, 0.30)}

    def sample(self, m: dict[str, Any], rng: np.random.Generator) -> dict[str, Any]:
        return {"joint_offset_rad": float(m["joint_offset_rad"])}

    def start_robot(self, raw: Any, p: Drawn, reset_seed: int) -> None:
        offset_joints(raw, p, reset_seed)


def offset_joints(raw: Any, p: Drawn, reset_seed: int) -> np.ndarray:
    """Offset the arm's joints for this reset; returns the offsets applied (radians)."""
    sim = raw.sim
    robot = raw.robots[0]
    joints = np.asarray(robot._ref_joint_pos_indexes)
    limit = float(p.params["joint_offset_rad"])
    rng = np.random.default_rng([p.seed, int(reset_seed) & 0xFFFFFFFF, 7])
    delta = rng.uniform(-limit, limit, len(joints))
    base = np.array(sim.data.qpos[joints], copy=True)
    low, high = _joint_limits(sim, robot)
    for scale in (1.0, 0.5, 0.25, 0.125, 0.0):
        sim.data.qpos[joints] = np.clip(base + scale * delta, low, high)
        sim.data.qvel[robot._ref_joint_vel_indexes] = 0.0
        sim.forward()
        if scale == 0.0 or not _robot_touches(sim, robot):
            return np.asarray(sim.data.qpos[joints] - base)
    return np.zeros(len(joints))


def _joint_limits(sim: Any, robot: Any) -> tuple[np.ndarray, np.ndarray]:
    model = sim.model._model
    ids = [model.joint(name).id for name in robot.robot_joints]
    ranges = model.jnt_range[ids]
    limited = (
        model.jnt_limited[ids].astype(bool) if hasattr(model, "jnt_limited") else np.ones(len(ids), bool)
    )
    low = np.where(limited, ranges[:, 0], -np.inf)
    high = np.where(limited, ranges[:, 1], np.inf)
    return low, high


def _robot_touches(sim: Any, robot: Any) -> bool:
    """Whether any arm or gripper geom penetrates anything else by more than a millimetre."""
    model, data = sim.model._model, sim.data._data
    names = [model.body(i).name for i in range(model.nbody)]
    mine = np.array([n.startswith(("robot0_", "gripper0_")) for n in names])
    for k in range(data.ncon):
        c = data.contact[k]
        a, b = mine[model.geom_bodyid[c.geom1]], mine[model.geom_bodyid[c.geom2]]
        if a != b and c.dist < -0.001:
            return True
    return False
