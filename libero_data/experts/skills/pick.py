"""Pick: grasp an object from above and lift it clear of its surroundings."""

from __future__ import annotations

import numpy as np

from libero_data.experts.geometry import yaw_of_closing
from libero_data.experts.grasp import plan_top_down
from libero_data.experts.motion import CLOSE, OPEN, Actions
from libero_data.experts.skills.base import SKILLS, Context, Skill, SkillFailed, lift, wait_until_still


@SKILLS.register("pick")
class Pick(Skill):
    """``pick(obj)``: top-down grasp planned on the collision geometry, then lift.

    Randomised per episode: which of the best grasps (within a small score margin), the
    pre-grasp height, the descent speed and the lift height.
    """

    name = "pick"

    def run(self, ctx: Context) -> Actions:
        (obj,) = self.args
        scene = ctx.scene
        yield from wait_until_still(ctx, obj)
        grasps = plan_top_down(scene, obj, yaw_reference=yaw_of_closing(scene.eef_mat()))
        if not grasps:
            raise SkillFailed(f"no top-down grasp fits {obj}")
        # Any grasp close to the best one is as good: pick among them for variety.
        good = [g for g in grasps if g.score > grasps[0].score - 1.0][:6]
        grasp = good[int(ctx.rng.integers(len(good)))]
        above = grasp.pos + np.array([0.0, 0.0, 0.08 + ctx.jitter(0.02) + 0.02])
        ctx.motion.gripper = OPEN
        # Rise first when low, so the hand does not sweep through nearby objects.
        here = scene.eef_pos()
        top = scene.aabb(obj)[1][2]
        if here[2] < top + 0.06:
            yield from lift(ctx, top + 0.08)
        yield from ctx.motion.move(above, grasp.mat, tol=0.01, max_steps=150)
        reached = yield from ctx.motion.move(grasp.pos, grasp.mat, speed=0.12 + ctx.jitter(0.03), tol=0.004)
        if not reached:
            # Blocked on the way down (usually by the object itself): one more slow push.
            yield from ctx.motion.move(grasp.pos, grasp.mat, speed=0.06, tol=0.006, max_steps=30)
        yield from ctx.motion.set_gripper(CLOSE, steps=10, mat=grasp.mat)
        if not scene.grasped(obj):
            yield from ctx.motion.set_gripper(OPEN, steps=6, mat=grasp.mat)
            yield from lift(ctx, grasp.pos[2] + 0.08)
            raise SkillFailed(f"missed {obj}")
        z0 = float(scene.pos(obj)[2])
        yield from lift(ctx, grasp.pos[2] + 0.06 + ctx.jitter(0.01), grasp.mat, speed=0.12)
        if not scene.grasped(obj) or scene.pos(obj)[2] < z0 + 0.02:
            yield from ctx.motion.set_gripper(OPEN, steps=6, mat=grasp.mat)
            yield from lift(ctx, scene.eef_pos()[2] + 0.05)
            raise SkillFailed(f"{obj} slipped while lifting")
        ctx.held = obj
        ctx.notes["grasp_mat"] = grasp.mat
        return True
