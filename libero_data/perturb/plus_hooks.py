"""The simulator's part of a LIBERO-Plus task (:mod:`libero_data.tasks.plus`): its agentview camera,
its arm's start, its added objects and its image noise, applied through the same hooks as our kinds
(:mod:`libero_data.perturb.apply`) from the perturbation record its BDDL file carries.

- **Camera** (every task: an unchanged view is still rounded as theirs is). Their problem classes
  place the agentview camera from its LIBERO pose: turned by ``-vert`` degrees about the line
  ``x = 0, z = 0.8`` parallel to y (where ``v`` is not 0), then by ``h`` degrees about the world's
  z axis; moved ``scale`` percent of its distance from the point ``(0, 0, 0.8)``; its orientation
  alone turned by ``rot`` degrees about z and ``-vert`` degrees about y. Each stage rounds position
  and quaternion to 4 decimals, as theirs does.
- **Robot** (``robot_start``: their ``MountedPanda<k>.init_qpos``). Their robot class makes LIBERO's
  reset put the arm there (``apply_scene`` sets the same on robosuite's robot); their evaluation
  then writes stored init state 0 over it with ``set_init_state``, and the arm controller, which
  read the perturbed pose at the reset, pulls the end effector toward that pose during the waiting
  steps (LIBERO's loop, :mod:`libero_data.sim.libero_loop`, reproduces this as it is). Outside that
  loop (``LiberoEnv.reset``: our protocol, the expert) the arm starts at their joint angles.
- **Added objects** (``objects``: category -> model file and rotation): made known to LIBERO's
  object registry before the scene is built (:mod:`libero_data.perturb.plus_objects`).
- **Scene** (light and background tasks: ``scene``): what their scene class changes of LIBERO's,
  applied to the built scene (:mod:`libero_data.perturb.plus_scene`).
- **Noise** (``noise`` 1-50): the agentview image only, one of their five corruptions at one of
  ten severities (:mod:`libero_data.perturb.plus_noise`), drawn from the perturbation's seed and
  the simulator's state.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from libero_data.perturb.kinds.base import Drawn

#: The perturbation record's kind (libero_data.tasks.plus.KIND).
KIND = "libero_plus"
CAMERA = "agentview"
#: The point their camera turns about and moves away from (x = 0, y free, z = 0.8 for the tilt).
PIVOT = (0.0, 0.0, 0.8)


class LiberoPlus:
    """The hooks of a LIBERO-Plus task (see the module docstring)."""

    name = KIND

    def prepare_build(self, p: Drawn) -> None:
        if p.params.get("objects"):
            from libero_data.perturb.plus_objects import register_objects

            register_objects(p.params["objects"])

    def apply_scene(self, raw: Any, p: Drawn) -> None:
        import mujoco

        params = p.params
        model, data = raw.sim.model._model, raw.sim.data._data
        cam = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_CAMERA, CAMERA)
        pos, quat = moved_camera(model.cam_pos[cam], model.cam_quat[cam], params["view"])
        model.cam_pos[cam] = pos
        model.cam_quat[cam] = np.asarray(quat) / np.linalg.norm(quat)  # as MuJoCo's compiler does
        if params.get("robot_start"):
            raw.robots[0].init_qpos = np.array(params["robot_start"], dtype=np.float64)
        mujoco.mj_kinematics(model, data)
        mujoco.mj_camlight(model, data)
        if params.get("scene"):
            from libero_data.perturb.plus_scene import apply_plus_scene

            apply_plus_scene(raw, params["scene"])

    def start_robot(self, raw: Any, p: Drawn, reset_seed: int) -> bool:
        start = p.params.get("robot_start")
        if not start:
            return False
        sim, robot = raw.sim, raw.robots[0]
        sim.data.qpos[robot._ref_joint_pos_indexes] = np.asarray(start, dtype=np.float64)
        sim.data.qvel[robot._ref_joint_vel_indexes] = 0.0
        sim.forward()
        return True

    def observe(self, obs: dict[str, Any], p: Drawn, cameras: tuple[str, ...]) -> None:
        severity = int(p.params.get("noise", 0))
        if severity and CAMERA in cameras and CAMERA in obs:
            import zlib

            from libero_data.perturb.plus_noise import corrupt

            state = np.ascontiguousarray(obs["sim_state"])
            rng = np.random.default_rng([p.seed, zlib.crc32(state.tobytes()), severity])
            obs[CAMERA] = corrupt(obs[CAMERA], severity, rng)


HOOKS = LiberoPlus()


def moved_camera(
    pos: Any, quat_wxyz: Any, view: list[int] | tuple[int, ...]
) -> tuple[list[float], list[float]]:
    """Their camera placement (module docstring) from LIBERO's pose ``pos``, ``quat_wxyz``."""
    h, v, scale, rot, vert = (int(x) for x in view)
    p = [float(x) for x in pos]
    q = [float(x) for x in quat_wxyz]
    if v != 0:
        p, q = _turned(p, q, _about_y(-v), PIVOT)
    p, q = _turned(p, q, _about_z(h), (0.0, 0.0, 0.0))
    if scale != 100:
        p = _rounded([c + (x - c) * (scale / 100) for x, c in zip(p, PIVOT, strict=True)])
        q = _rounded(q)
    if rot != 0:
        q = _rounded(_multiply(_about_z(rot), _unit(q)))
    if vert != 0:
        q = _rounded(_multiply(_about_y(-vert), _unit(q)))
    return p, q


def _turned(
    p: list[float], q: list[float], r: list[float], centre: tuple[float, ...]
) -> tuple[list[float], list[float]]:
    """Position turned by the rotation ``r`` (a quaternion) about ``centre``, orientation by ``r``."""
    offset = [x - c for x, c in zip(p, centre, strict=True)]
    turned = _rotate(r, offset)
    return _rounded([x + c for x, c in zip(turned, centre, strict=True)]), _rounded(_multiply(r, _unit(q)))


def _about_y(degrees: float) -> list[float]:
    a = math.radians(degrees) / 2
    return [math.cos(a), 0.0, math.sin(a), 0.0]


def _about_z(degrees: float) -> list[float]:
    a = math.radians(degrees) / 2
    return [math.cos(a), 0.0, 0.0, math.sin(a)]


def _multiply(a: list[float], b: list[float]) -> list[float]:
    """The quaternion product ``a b`` (w, x, y, z): ``b`` first, then ``a``."""
    aw, ax, ay, az = a
    bw, bx, by, bz = b
    return [
        aw * bw - ax * bx - ay * by - az * bz,
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
    ]


def _unit(q: list[float]) -> list[float]:
    """``q`` scaled to length 1 (their rotations take a stored quaternion as a unit one)."""
    n = math.sqrt(sum(x * x for x in q))
    return [x / n for x in q]


def _rotate(q: list[float], v: list[float]) -> list[float]:
    """The vector ``v`` turned by the unit quaternion ``q``."""
    _w, x, y, z = _multiply(_multiply(q, [0.0, *v]), [q[0], -q[1], -q[2], -q[3]])
    return [x, y, z]


def _rounded(values: list[float]) -> list[float]:
    return [round(float(v), 4) for v in values]
