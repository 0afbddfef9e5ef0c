"""Push an object along the table into a region (for flat objects that cannot be grasped)."""

from __future__ import annotations

import numpy as np

from libero_data.bddl import Atom
from libero_data.experts.geometry import top_down, wrap_half_turn, yaw_of_closing
from libero_data.experts.grasp import hand_collisions
from libero_data.experts.motion import CLOSE, Actions
from libero_data.experts.skills.base import SKILLS, Context, Skill, SkillFailed, lift


@SKILLS.register("push")
class Push(Skill):
    """``push(obj, target)``: closed fingertips behind the object slide it to the target.

    Each stroke starts where the gripper fits behind the object (the hand turned across or
    along the stroke, the stroke bent up to 60 degrees away from the straight line when
    something stands in the way) and is re-aimed from where the object actually is.
    Randomised: contact height and stroke length.
    """

    name = "push"

    def run(self, ctx: Context) -> Actions:
        obj, target = self.args
        scene = ctx.scene
        goal = scene.pos(target)[:2] if ctx.is_entity(target) else scene.site(target).pos[:2]
        atom = Atom("On", (obj, target))
        ctx.motion.gripper = CLOSE
        for _ in range(8):
            if scene.env.holds(atom):
                break
            body = scene.pos(obj)[:2]
            delta = goal - body
            dist = float(np.linalg.norm(delta))
            stroke = _stroke(ctx, obj, delta / max(dist, 1e-9))
            if stroke is None:
                raise SkillFailed(f"no room to push {obj}")
            start, direction, mat = stroke
            along = float(direction @ delta)
            yield from lift(ctx, start[2] + 0.06)
            yield from ctx.motion.move(start + np.array([0, 0, 0.06]), mat, tol=0.01, max_steps=120)
            yield from ctx.motion.move(start, mat, speed=0.1, tol=0.006, max_steps=40)
            length = min(max(along, 0.02), 0.15) + 0.01 + ctx.jitter(0.004)
            # Aim a little below the start height: the rim's slope pushes a compliant arm up.
            end = start + np.array([*(direction * length), -0.012])
            yield from ctx.motion.move(end, mat, speed=0.1, tol=0.006, max_steps=80)
        yield from lift(ctx, scene.eef_pos()[2] + 0.06)
        if not scene.env.holds(atom):
            raise SkillFailed(f"could not push {obj} onto {target}")
        return True


def _stroke(ctx: Context, obj: str, ideal: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """Start point, direction and gripper orientation of a collision-free stroke."""
    scene = ctx.scene
    pts = scene.points(obj)
    body = scene.pos(obj)[:2]
    top = float(pts[:, 2].max())
    z = max(top - 0.008 + ctx.jitter(0.002), ctx.table_height() + 0.014)
    others = scene.obstacle_points(exclude=(obj,))
    near = np.linalg.norm(others[:, :2] - body, axis=1) < 0.35
    others = others[near]
    base_yaw = float(np.arctan2(ideal[1], ideal[0]))
    now = yaw_of_closing(scene.eef_mat())
    for bend in (0.0, 0.3, -0.3, 0.6, -0.6, 0.9, -0.9, 1.2, -1.2):
        yaw = base_yaw + bend
        direction = np.array([np.cos(yaw), np.sin(yaw)])
        back = float(-((pts[:, :2] - body) @ direction).min())
        for standoff in (0.022, 0.045):
            start = np.array([*(body - direction * (back + standoff)), z])
            for turn in (np.pi / 2, np.pi / 4, -np.pi / 4, 0.0):
                mat = top_down(wrap_half_turn(yaw + turn, now))
                if hand_collisions(others, start, mat) == 0 and hand_collisions(pts, start, mat) == 0:
                    return start, direction, mat
    return None
