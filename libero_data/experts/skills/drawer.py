"""Open and close a sliding drawer by its handle."""

from __future__ import annotations

import numpy as np

from libero_data.experts.geometry import approach_frame
from libero_data.experts.motion import CLOSE, OPEN, Actions
from libero_data.experts.skills.articulation import Part, holds, part_of
from libero_data.experts.skills.base import SKILLS, Context, Skill, SkillFailed, lift


def _handle(ctx: Context, part: Part) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Handle centre, the direction the drawer opens in (world), and the handle's long axis."""
    scene = ctx.scene
    body = scene.body_id(part.joint.body)
    pts = scene.points_of_bodies(scene.subtree(body))
    out = part.joint.axis * part.open_sign  # the drawer moves along +axis when qpos grows
    proj = pts @ out
    front = pts[proj > proj.max() - 0.012]
    centre = front.mean(0)
    # The handle's long axis: the horizontal direction of largest spread of the front points.
    flat = front[:, :2] - front[:, :2].mean(0)
    _, _, vt = np.linalg.svd(flat, full_matrices=False)
    long_axis = np.array([vt[0][0], vt[0][1], 0.0])
    return centre, out / np.linalg.norm(out), long_axis


def _grip_frame(out: np.ndarray, long_axis: np.ndarray, pitch: float, current: np.ndarray) -> np.ndarray:
    """Gripper pointing into the drawer front, tilted down by ``pitch`` rad, fingers across the bar.

    Of the two equivalent finger orders, the one nearer the current wrist is used.
    """
    down = np.array([0.0, 0.0, -1.0])
    approach = -out * np.cos(pitch) + down * np.sin(pitch)
    closing = np.cross(approach, long_axis)
    if closing @ current[:, 0] < 0:
        closing = -closing
    return approach_frame(approach, closing)


@SKILLS.register("open_drawer")
class OpenDrawer(Skill):
    """``open_drawer(region)``: grasp the handle from the front (tilted down) and pull it out.

    Randomised: approach tilt, standoff and the extra pull beyond the open threshold.
    """

    name = "open_drawer"

    def run(self, ctx: Context) -> Actions:
        (region,) = self.args
        part = part_of(ctx, region)
        centre, out, bar = _handle(ctx, part)
        pitch = np.deg2rad(0 + ctx.jitter(4))
        mat = _grip_frame(out, bar, pitch, ctx.scene.eef_mat())
        approach = mat[:, 2]
        grip = centre + approach * 0.012
        ctx.motion.gripper = OPEN
        yield from lift(ctx, centre[2] + 0.06)
        yield from ctx.motion.move(
            grip - approach * 0.09 + np.array([0, 0, 0.02]), mat, tol=0.01, max_steps=150
        )
        yield from ctx.motion.move(grip, mat, speed=0.1, tol=0.005, max_steps=60)
        yield from ctx.motion.set_gripper(CLOSE, steps=10, mat=mat)
        target = abs(part.joint.range[1] - part.joint.range[0]) * 0.95
        start = ctx.scene.eef_pos()
        for _ in range(4):
            pulled = part.opened_by(ctx)
            if holds(ctx, "Open", region) and pulled > 0.85 * target:
                break
            goal = start + out * (target + 0.01 + ctx.jitter(0.005))
            yield from ctx.motion.move(goal, mat, speed=0.12, tol=0.006, max_steps=60)
        yield from ctx.motion.set_gripper(OPEN, steps=6, mat=mat)
        back = ctx.scene.eef_pos() + out * 0.06 + np.array([0, 0, 0.05])
        yield from ctx.motion.move(back, mat, tol=0.02, max_steps=40)
        if not holds(ctx, "Open", region):
            raise SkillFailed(f"{region} did not open")
        return True


@SKILLS.register("close_drawer")
class CloseDrawer(Skill):
    """``close_drawer(region)``: push the drawer front with the closed fingers until it shuts."""

    name = "close_drawer"

    def run(self, ctx: Context) -> Actions:
        (region,) = self.args
        part = part_of(ctx, region)
        centre, out, _bar = _handle(ctx, part)
        ctx.motion.gripper = CLOSE
        mat = ctx.current_top_down()
        # Push just below the handle with the finger tips, from in front of it.
        push_at = centre + np.array([0, 0, -0.01 + ctx.jitter(0.004)])
        yield from lift(ctx, centre[2] + 0.08)
        yield from ctx.motion.move(
            push_at + out * 0.07 + np.array([0, 0, 0.06]), mat, tol=0.012, max_steps=150
        )
        yield from ctx.motion.move(push_at + out * 0.05, mat, speed=0.15, tol=0.008, max_steps=60)
        travel = abs(part.joint.range[1] - part.joint.range[0]) + 0.03
        for _ in range(3):
            if holds(ctx, "Close", region):
                break
            here = ctx.scene.eef_pos()
            yield from ctx.motion.move(here - out * travel, mat, speed=0.15, tol=0.01, max_steps=50)
        yield from ctx.motion.move(
            ctx.scene.eef_pos() + out * 0.05 + np.array([0, 0, 0.04]), mat, tol=0.02, max_steps=30
        )
        if not holds(ctx, "Close", region):
            raise SkillFailed(f"{region} did not close")
        return True
