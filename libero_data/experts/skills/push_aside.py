"""Push aside: slide an object out of a drawer's way in one stroke before the drawer opens."""

from __future__ import annotations

import numpy as np

from libero_data.experts.motion import CLOSE, OPEN, Actions
from libero_data.experts.skills.base import SKILLS, Context, Skill, lift, upright
from libero_data.experts.skills.drawer import covered_by_opening, grasp_left_open, sweep
from libero_data.experts.skills.pick import COMFORTABLE_REACH, Pick
from libero_data.experts.skills.push import inside_push_start, push_stroke
from libero_data.experts.skills.set_aside import SetAside

#: Clearance beyond what ``covered_by_opening`` asks for (m): the push stops a little short.
EXTRA = 0.015
#: Longest stroke tried (m); beyond it the object is picked and set down instead.
LONGEST = 0.14
#: How much further than the shortest distance that leaves a good grasp an object is pushed (m):
#: pushed just that far, grasps were marginal and descents onto them stuck.
SPARE = 0.03


@SKILLS.register("push_aside")
class PushAside(Skill):
    """``push_aside(obj, region)``: one stroke of the closed finger tips at the object's foot,
    the shortest way out of the drawer's sweep (as a hand clears a bowl from in front of a
    drawer), then the hand back up; where no stroke fits (no room, out of reach, too far) the
    object is picked and set down beside the sweep instead (:class:`SetAside`).

    Randomised: the stroke's contact height and a few mm of its length.
    """

    name = "push_aside"

    def run(self, ctx: Context) -> Actions:
        obj, region = self.args
        scene = ctx.scene
        if not covered_by_opening(scene, region, obj) or grasp_left_open(scene, region, obj):
            return True
        ctx.phase = "push"
        for direction, distance in _ways_out(ctx, obj, region):
            stroke = _stroke(ctx, obj, direction, distance)
            if stroke is None:
                continue
            start, end, mat = stroke
            ctx.motion.gripper = CLOSE
            yield from upright(ctx, height=float(scene.aabb(obj)[1][2]) + 0.1)
            yield from lift(ctx, start[2] + 0.06)
            yield from ctx.motion.move(start + np.array([0, 0, 0.06]), mat, tol=0.01, max_steps=120)
            yield from ctx.motion.move(
                start + np.array([0, 0, 0.02]), mat, speed=0.25, tol=0.008, max_steps=30
            )
            yield from ctx.motion.move(start, mat, speed=0.12, tol=0.006, max_steps=30)
            yield from ctx.motion.move(end, mat, speed=0.2, tol=0.008, max_steps=60, stall=4)
            yield from lift(ctx, scene.eef_pos()[2] + 0.03)
            ctx.motion.gripper = OPEN
            if not covered_by_opening(scene, region, obj) or grasp_left_open(scene, region, obj):
                return True
            break
        ctx.phase = None
        yield from Pick(obj).run(ctx)
        return (yield from SetAside(obj, region).run(ctx))


def _stroke(
    ctx: Context, obj: str, direction: np.ndarray, distance: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """Where the closed finger tips start and end (grip site) and the hand's orientation, for
    moving ``obj`` by ``distance`` along ``direction``: from behind it at its foot where the hand
    fits there, else (a bowl against a cabinet) from inside it, the tips against its far wall."""
    scene = ctx.scene
    body = scene.pos(obj)[:2]
    stroke = push_stroke(ctx, obj, direction, set())
    if stroke is not None:
        start, way, mat, _ = stroke
        if float(way @ direction) >= np.cos(np.deg2rad(20)):  # not bent round an obstacle
            length = distance + float((body - start[:2]) @ way) + EXTRA + ctx.jitter(0.004)
            return start, start + np.array([*(way * length), -0.02]), mat
    inside = inside_push_start(ctx, obj, direction)
    if inside is None:
        return None
    start, mat = inside
    length = distance + EXTRA + ctx.jitter(0.004)
    return start, start + np.array([*(direction * length), -0.01]), mat


def _ways_out(ctx: Context, obj: str, region: str) -> list[tuple[np.ndarray, float]]:
    """Directions (unit xy) and distances that take ``obj`` clear of the drawer's sweep, the
    shortest first, keeping the object within comfortable reach."""
    scene = ctx.scene
    lo, hi = sweep(scene, region)
    olo, ohi = scene.aabb(obj)
    margin = 0.04 + 0.005  # covered_by_opening's, and a little more
    shoulder = scene.shoulder_pos()
    ways = []
    for axis in (0, 1):
        for sign in (-1.0, 1.0):
            direction = np.zeros(2)
            direction[axis] = sign
            distance = (ohi[axis] - lo[axis] + margin) if sign < 0 else (hi[axis] - olo[axis] + margin)
            # Far enough for a grasp as good as now once the drawer is open, if that is less: the
            # first distance from which 3 cm more still leaves one (the push ends that much further).
            for shorter in np.arange(0.02, min(distance, LONGEST) - SPARE, 0.01):
                if grasp_left_open(scene, region, obj, shift=direction * shorter) and grasp_left_open(
                    scene, region, obj, shift=direction * (shorter + SPARE)
                ):
                    distance = float(shorter) + SPARE
                    break
            if distance <= 0 or distance > LONGEST:
                continue
            end = scene.pos(obj)[:2] + direction * distance
            if float(np.linalg.norm(np.array([*end, olo[2] + 0.05]) - shoulder)) > COMFORTABLE_REACH:
                continue
            ways.append((direction, float(distance)))
    return sorted(ways, key=lambda w: w[1])
