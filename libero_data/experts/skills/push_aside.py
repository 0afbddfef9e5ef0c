"""Push aside: slide an object out of a drawer's way in one stroke before the drawer opens."""

from __future__ import annotations

import numpy as np

from libero_data.experts.motion import CLOSE, OPEN, Actions
from libero_data.experts.skills.base import SKILLS, Context, Skill, lift, upright
from libero_data.experts.skills.drawer import covered_by_opening, sweep
from libero_data.experts.skills.pick import COMFORTABLE_REACH, Pick
from libero_data.experts.skills.push import push_stroke
from libero_data.experts.skills.set_aside import SetAside

#: Clearance beyond what ``covered_by_opening`` asks for (m): the push stops a little short.
EXTRA = 0.015
#: Longest stroke tried (m); beyond it the object is picked and set down instead.
LONGEST = 0.14


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
        if not covered_by_opening(scene, region, obj):
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
            yield from ctx.motion.move(start, mat, speed=0.12, tol=0.006, max_steps=40)
            yield from ctx.motion.move(end, mat, speed=0.12, tol=0.006, max_steps=60, stall=6)
            yield from lift(ctx, scene.eef_pos()[2] + 0.06)
            ctx.motion.gripper = OPEN
            if not covered_by_opening(scene, region, obj):
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
    inside = _inside_start(ctx, obj, direction)
    if inside is None:
        return None
    start, mat = inside
    length = distance + EXTRA + ctx.jitter(0.004)
    return start, start + np.array([*(direction * length), -0.01]), mat


def _inside_start(ctx: Context, obj: str, direction: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """For a hollow object (a bowl): the grip site with the finger tips on its floor just inside
    the wall it is pushed toward, and a hand turned across the push; None for a solid one or
    where the hand does not fit."""
    from libero_data.experts.geometry import top_down, wrap_half_turn, yaw_of_closing
    from libero_data.experts.grasp import TIP_BELOW_SITE, hand_collisions

    scene = ctx.scene
    pts = scene.points(obj)
    body = scene.pos(obj)[:2]
    lo, hi = pts.min(0), pts.max(0)
    radius = float(np.max(hi[:2] - lo[:2])) / 2
    middle = np.linalg.norm(pts[:, :2] - body, axis=1) < radius / 3
    if not middle.any() or float(pts[middle, 2].max()) > hi[2] - 0.025:
        return None
    tip_xy = body + direction * (radius - INSIDE_INSET)
    near_tip = np.linalg.norm(pts[:, :2] - tip_xy, axis=1) < 0.01
    floor = float(pts[near_tip, 2].max()) if near_tip.any() else float(lo[2])
    start = np.array([*tip_xy, floor + TIP_BELOW_SITE + 0.008])
    yaw = wrap_half_turn(float(np.arctan2(direction[1], direction[0])) + np.pi / 2, yaw_of_closing(scene.eef_mat()))
    mat = top_down(yaw)
    others = scene.obstacle_points(exclude=(obj,))
    others = others[np.linalg.norm(others[:, :2] - body, axis=1) < 0.3]
    if hand_collisions(others, start, mat):
        return None
    return start, mat


#: How far inside the wall the finger tips go down in a hollow object (m): room for the
#: fingers' thickness and the wall's slope.
INSIDE_INSET = 0.025


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
            distance = (ohi[axis] - lo[axis] + margin) if sign < 0 else (hi[axis] - olo[axis] + margin)
            if distance <= 0 or distance > LONGEST:
                continue
            direction = np.zeros(2)
            direction[axis] = sign
            end = scene.pos(obj)[:2] + direction * distance
            if float(np.linalg.norm(np.array([*end, olo[2] + 0.05]) - shoulder)) > COMFORTABLE_REACH:
                continue
            ways.append((direction, float(distance)))
    return sorted(ways, key=lambda w: w[1])
