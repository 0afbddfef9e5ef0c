"""Pick: grasp an object from above and lift it clear of its surroundings."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from libero_data.experts.geometry import approach_frame, top_down, yaw_of_closing
from libero_data.experts.grasp import MAX_OPENING, GraspSearch, has_top_down_grasp, plan_top_down
from libero_data.experts.motion import CLOSE, OPEN, Actions
from libero_data.experts.skills.base import (
    SKILLS,
    Context,
    Skill,
    SkillFailed,
    lift,
    upright,
    wait_until_still,
)


@SKILLS.register("pick")
class Pick(Skill):
    """``pick(obj)``: top-down grasp planned on the collision geometry, then lift.

    Randomised per episode: which of the best grasps (within a small score margin), the
    pre-grasp height, the descent speed and the lift height.
    """

    name = "pick"

    def run(self, ctx: Context) -> Actions:
        obj, *rest = self.args
        scene = ctx.scene
        insertion = False
        if rest and scene.has_site(rest[0]):
            from libero_data.experts.skills.insert import is_enclosed

            insertion = is_enclosed(ctx, scene.site(rest[0]))
        # Up to three tries; after a miss the grasps are planned again (the object may have
        # moved) and spots within 2 cm of a missed one are skipped, and so is the missed rim's
        # side of a wide object (:func:`_away_from_misses`).
        missed: list[np.ndarray] = []
        ctx.phase = "approach"
        # A hand tilted by up to 55 degrees (after hooking a drawer open) turns on its way.
        yield from upright(ctx, height=float(scene.aabb(obj)[1][2]) + 0.12, within=55.0)
        if not insertion and not has_top_down_grasp(scene, obj):
            # Boxed in (a pudding pressed against a bowl): slide it a few cm into the open.
            yield from _nudge_into_the_open(ctx, obj)
        for attempt in range(3):
            yield from wait_until_still(ctx, obj)
            grasps = _plan(scene, obj)
            if insertion:
                grasps = _for_side_insertion(ctx, obj, grasps)
            elif not missed:
                # Reach re-ranks the first try only: after a miss the best-scoring grasp goes
                # first (on libero_spatial/7 the near rims it prefers missed again and again,
                # where the side rim, ranked first by score, held at once).
                grasps = _within_reach(ctx, grasps, obj, rest[0] if rest else None)
            grasps = _away_from_misses(scene, obj, grasps, missed)
            if not grasps:
                raise SkillFailed(f"no top-down grasp fits {obj}" if not missed else f"missed {obj}")
            if attempt == 0:
                # Any grasp close to the best one is as good: pick among them for variety.
                # (Only as deep as the best: a shallow rim grasp slips.)
                best = grasps[0]
                good = [
                    g
                    for g in grasps
                    if g.score > best.score - GOOD_MARGIN and g.pos[2] <= best.pos[2] + SAME_DEPTH
                ][:6] or grasps[:1]
                grasp = good[int(ctx.rng.integers(len(good)))]
            else:
                grasp = grasps[0]
            ctx.notes["regrasp"] = attempt > 0
            ctx.notes["insertion"] = insertion
            if (yield from _attempt(ctx, obj, grasp)):
                break
            missed.append(grasp.pos)
        else:
            raise SkillFailed(f"missed {obj}")
        ctx.held = obj
        ctx.notes["grasp_mat"] = grasp.mat
        ctx.notes["grasp_width"] = grasp.width
        return True


#: A best open-hand grasp scoring below this is poor (far off-centre, shallow, or closing
#: along a rim instead of across it): then pre-shaped grasps are planned as well.
POOR_GRASP = 0.0
#: Finger opening of a pre-shaped hand (m): room for a bowl's wall and 1-2 cm on each side.
PRESHAPED_OPENING = 0.04


#: After a rim grasp missed, rim grasps less than this (rad) round the object from it are
#: skipped: what made it miss (a bowl tilted on a burner's grate) is there too. On
#: libero_spatial/7 the second and third tries 2-4 cm along the same rim missed as the first.
SAME_SIDE = np.deg2rad(50.0)


def _away_from_misses(scene, obj: str, grasps: list, missed: list[np.ndarray]) -> list:
    """``grasps`` without those near a missed one: within ``MISS_RADIUS``, or (for grasps off
    the object's centre) on the same side of it as an off-centre miss. If that leaves none,
    only the first rule applies."""
    near = [g for g in grasps if all(np.linalg.norm(g.pos[:2] - m[:2]) >= MISS_RADIUS for m in missed)]
    centre = scene.com(obj)[:2]

    def bearing(xy: np.ndarray) -> float | None:
        offset = xy[:2] - centre
        return float(np.arctan2(offset[1], offset[0])) if np.linalg.norm(offset) > 0.02 else None

    sides = [b for b in (bearing(m) for m in missed) if b is not None]

    def other_side(g) -> bool:
        b = bearing(g.pos)
        return b is None or all(abs((b - s + np.pi) % (2 * np.pi) - np.pi) >= SAME_SIDE for s in sides)

    return [g for g in near if other_side(g)] or near


def _plan(scene, obj: str) -> list:
    """Top-down grasps of ``obj``, best first: open hand, then looser and pre-shaped rules.

    A light bowl with thin walls (LIBERO's white bowl: 2 g, 8 cm wide, 2-mm walls) has no
    good open-hand grasp: the fully open fingers cannot go inside it without reaching the far
    wall, and a pinch along its rim squeezes it out of the hand. A hand pre-shaped to 4 cm
    can put one finger inside and pinch the wall across.
    """
    yaw_reference = yaw_of_closing(scene.eef_mat())
    grasps = plan_top_down(scene, obj, yaw_reference=yaw_reference)
    if not grasps:  # thin flared rims (some bowls) need a looser contact rule
        grasps = plan_top_down(
            scene, obj, yaw_reference=yaw_reference, search=GraspSearch(pad_tolerance=0.008)
        )
    if not grasps or grasps[0].score < POOR_GRASP:
        preshaped = plan_top_down(
            scene, obj, yaw_reference=yaw_reference, search=GraspSearch(opening=PRESHAPED_OPENING)
        )
        grasps = sorted(grasps + preshaped, key=lambda g: -g.score)
    return grasps


def _attempt(ctx: Context, obj: str, grasp) -> Actions:
    """One grasp: approach from above, close, lift a little; False (gripper open) if it failed."""
    scene = ctx.scene
    grasp = _leaning_back(ctx, _within_wrist(ctx, grasp))
    label = lambda phase: "regrasp" if ctx.notes.get("regrasp") else phase  # noqa: E731
    ctx.phase = label("approach")
    rise = 0.08 + ctx.jitter(0.02) + 0.02
    above = grasp.pos - grasp.mat[:, 2] * rise
    ctx.motion.gripper = OPEN
    # Rise first when low, so the hand does not sweep through nearby objects.
    here = scene.eef_pos()
    top = scene.aabb(obj)[1][2]
    if here[2] < top + 0.06:
        yield from lift(ctx, top + 0.08)
    # Travel above whatever lies between here and there (a basket just dropped into), or
    # the finger tips catch its rim and drag it along. What stands around the object itself
    # (a shelf over it) is the grasp planner's business: the path stops 8 cm short of it.
    start = scene.eef_pos()
    gap = above[:2] - start[:2]
    if np.linalg.norm(gap) > 0.08:
        short_of = above[:2] - gap / np.linalg.norm(gap) * 0.08
        clear = ctx.clear_height(start, short_of, (), radius=0.06) + 0.05
    else:
        clear = -np.inf
    if clear > max(start[2], above[2]):
        yield from lift(ctx, clear)
        yield from ctx.motion.move(np.array([above[0], above[1], clear]), grasp.mat, tol=0.015, max_steps=150)
    yield from ctx.motion.move(above, grasp.mat, tol=0.01, max_steps=150)
    if _elbow_at_stop(ctx):
        # Beyond TOO_CLOSE's reach but still too close for this table's height: the arm would
        # hold the object and fail to lift it (the hand drags it along the table instead).
        leaned = _leaning_back(ctx, grasp, close=True)
        if leaned is not grasp:
            grasp = leaned
            above = grasp.pos - grasp.mat[:, 2] * rise
            yield from ctx.motion.move(above, grasp.mat, tol=0.01, max_steps=150)
    ctx.phase = label("descend")
    if grasp.opening < MAX_OPENING:
        yield from ctx.motion.preshape(grasp.opening, mat=grasp.mat)
    descent = 0.12 + ctx.jitter(0.03)
    if not ctx.notes.get("insertion"):
        # Twice the pace down to 6 cm above the grasp, then slowly onto it: the finger tips
        # stop 2-3 cm above a bowl's rim (4 cm above the grasp, they knocked it askew before the
        # grasp). Not for an object to be carried in from the side, whose grasp decides whether
        # the hand fits: on libero_10/9 the mug then more often had to be laid in instead.
        near = grasp.pos - grasp.mat[:, 2] * DESCENT_SLOW
        yield from ctx.motion.move(near, grasp.mat, speed=2.0 * descent, tol=0.008, max_steps=40)
    # Blocked on the way down (usually by the object itself, or a finger on an open drawer's
    # edge): given up once 8 steps gain nothing (it pressed on for up to 120 before), then one
    # more slow push.
    reached = yield from ctx.motion.move(grasp.pos, grasp.mat, speed=descent, tol=0.004, stall=8)
    if not reached:
        yield from ctx.motion.move(grasp.pos, grasp.mat, speed=0.06, tol=0.006, max_steps=30, stall=8)
    ctx.phase = label("grasp")
    yield from ctx.motion.set_gripper(CLOSE, steps=10, mat=grasp.mat)
    if not scene.grasped(obj):
        yield from ctx.motion.set_gripper(OPEN, steps=6, mat=grasp.mat)
        yield from lift(ctx, grasp.pos[2] + 0.08)
        return False
    z0 = float(scene.pos(obj)[2])
    ctx.phase = label("lift")
    yield from lift(ctx, grasp.pos[2] + 0.06 + ctx.jitter(0.01), grasp.mat, speed=0.12)
    if not scene.grasped(obj) or scene.pos(obj)[2] < z0 + 0.02:
        yield from ctx.motion.set_gripper(OPEN, steps=6, mat=grasp.mat)
        yield from lift(ctx, scene.eef_pos()[2] + 0.05)
        return False
    return True


#: Horizontal grip-to-shoulder distance (m) below which a top-down hand needs the elbow
#: folded past its limit (on the low living-room table a grip 0.262 m from the shoulder is out
#: of reach and one 0.283 m away within it: the limit lies between).
TOO_CLOSE = 0.275
#: How far the hand leans back toward the robot then (the wrist moves out, the elbow opens).
LEAN_BACK = np.deg2rad(25.0)
#: The elbow's (robot0_joint4's) least distance from its folded stop (rad) with the hand above
#: a top-down grasp, below which the grasp leans back too. On a low table a grip beyond
#: TOO_CLOSE can still need the elbow folded to its stop: on LIBERO-PRO's libero_10_swap/0 a
#: soup can 0.30-0.33 m from the shoulder left 0.05-0.11 rad, was held, and could not be lifted
#: (the hand slid toward the robot dragging it). Elsewhere the slack stays above 0.15.
ELBOW_ROOM = 0.15


#: Last arm joint angle (rad) a grasp may leave the wrist at; its stop is at 2.90. Holding
#: an object there, the arm cannot keep the hand's orientation while it moves and stalls
#: short of where it is sent: after a regrasp that left the wrist near its stop, a carried bowl
#: stopped short of the plate (benchmarks/RESULTS.md, Expert: where the steps go).
WRIST_ROOM = 2.6


def _within_wrist(ctx: Context, grasp):
    """The grasp, or its half-turned twin (a parallel gripper is symmetric) where turning
    to it would take the last joint beyond ``WRIST_ROOM``."""
    if not np.allclose(grasp.mat, top_down(grasp.yaw)):
        return grasp
    turn = (grasp.yaw - yaw_of_closing(ctx.scene.eef_mat()) + np.pi) % (2 * np.pi) - np.pi
    q7 = ctx.scene.joint("robot0_joint7").qpos - turn  # a turn about +z turns the joint back
    if abs(q7) <= WRIST_ROOM:
        return grasp
    yaw = grasp.yaw + np.pi * np.sign(q7)
    return replace(grasp, yaw=yaw, mat=top_down(yaw))


def _elbow_at_stop(ctx: Context) -> bool:
    """Whether the elbow is within ``ELBOW_ROOM`` of its folded stop."""
    elbow = ctx.scene.joint("robot0_joint4")
    return elbow.qpos - elbow.range[0] < ELBOW_ROOM


def _leaning_back(ctx: Context, grasp, close: bool = False):
    """The grasp, its hand tilted about the closing axis toward the robot if it is too close
    (nearer the shoulder than ``TOO_CLOSE``, or ``close`` said so by the arm's elbow).

    Only the tilt component across the closing axis helps; fingers closing toward the robot
    are not tilted (they would no longer face the object's sides). A grasp already tilted
    is returned as it is.
    """
    to_robot = ctx.scene.shoulder_pos()[:2] - grasp.pos[:2]
    distance = float(np.linalg.norm(to_robot))
    if distance >= TOO_CLOSE and not close:
        return grasp
    if close and grasp.mat[2, 2] > -0.999:  # its approach is not straight down
        return grasp
    closing = grasp.mat[:, 0]
    across = np.array([*to_robot, 0.0]) / max(distance, 1e-9)
    across = across - closing * float(across @ closing)
    if np.linalg.norm(across) < 0.5:
        return grasp
    across /= np.linalg.norm(across)
    approach = np.array([0.0, 0.0, -1.0]) * np.cos(LEAN_BACK) + across * np.sin(LEAN_BACK)
    return replace(grasp, mat=approach_frame(approach, closing))


def _nudge_into_the_open(ctx: Context, obj: str, distance: float = 0.05) -> Actions:
    """Push the object ``distance`` away from what crowds it (closed finger tips, low)."""
    from libero_data.experts.skills.push import push_stroke

    scene = ctx.scene
    lo, hi = scene.aabb(obj)
    others = scene.obstacle_points(exclude=(obj,))
    crowd = others[
        np.all((others[:, :2] > lo[:2] - 0.05) & (others[:, :2] < hi[:2] + 0.05), axis=1)
        & (others[:, 2] > lo[2] + 0.01)
    ]
    if len(crowd) == 0:
        return False
    away = scene.pos(obj)[:2] - crowd[:, :2].mean(0)
    if np.linalg.norm(away) < 1e-6:
        return False
    stroke = push_stroke(ctx, obj, away / np.linalg.norm(away), set())
    if stroke is None:
        return False
    start, direction, mat, _ = stroke
    ctx.motion.gripper = CLOSE
    yield from lift(ctx, start[2] + 0.08)
    yield from ctx.motion.move(start + np.array([0, 0, 0.06]), mat, tol=0.01, max_steps=120)
    yield from ctx.motion.move(start, mat, speed=0.1, tol=0.006, max_steps=40)
    # From behind the object to where its body should end up: it moves about ``distance``.
    travel = float((scene.pos(obj)[:2] - start[:2]) @ direction) + distance + ctx.jitter(0.005)
    end = start + np.array([*(direction * travel), -0.02])
    yield from ctx.motion.move(end, mat, speed=0.1, tol=0.006, max_steps=60)
    yield from lift(ctx, scene.eef_pos()[2] + 0.08)
    ctx.motion.gripper = OPEN
    yield from upright(ctx, height=float(scene.aabb(obj)[1][2]) + 0.12)
    return True


#: Grasps scoring within this of the best are as good as it (score points), if they go as
#: deep as it (within SAME_DEPTH, m): a shallow rim grasp slips.
GOOD_MARGIN = 1.0
SAME_DEPTH = 0.004
#: How far above the grasp (m) a descent slows down.
DESCENT_SLOW = 0.06
REACH_MARGIN = 1.5
#: After a miss, grasps within this (m) of the missed one are skipped: what made it miss
#: (a wall that tips, a burner under a finger) is usually still there 2 cm away.
MISS_RADIUS = 0.02
#: Grip-site distance from the shoulder (m) beyond which a top-down hand nears the
#: straight-elbow limit (the arm locks straight at about 0.84 m and cannot pull back in).
COMFORTABLE_REACH = 0.79
#: A grasp this much (m) within comfortable reach is close at hand: where it sets the object
#: down does not re-rank it (the stall ``PLACING_REACH`` guards against came after a grasp near
#: the edge of reach, a bowl on a cabinet top).
CLOSE_AT_HAND = 0.15
#: Setting an object down takes fine moves at the end of the way: there the hand should
#: stay closer: a bowl held on its far rim puts the hand further out over the plate than one
#: held on its near rim, far enough for the straight elbow to stall (on libero_spatial/9 the
#: far rim put the hand 0.77 m out and stalled, the near rim 0.74 m and did not).
PLACING_REACH = 0.75


def _within_reach(ctx: Context, grasps: list, obj: str | None = None, target: str | None = None) -> list:
    """Re-rank grasps far from the robot: each cm beyond a comfortable reach costs 1 score point
    (of the grasps as deep as the best; shallower ones follow them).

    A far object (a bowl at the table's far edge) grasped on its far rim leaves the arm
    stretched straight, and from there it cannot carry the object back toward itself; its
    near rim is as good a grasp and a few cm closer. The same holds where the object is set
    down: with ``target`` given, the hand's place over the target (the object held the same
    way) counts too, so a bowl bound for a far plate is held on its near rim.
    """
    scene = ctx.scene
    shoulder = scene.shoulder_pos()
    shift = None
    if obj is not None and target is not None:
        goal = _target_point(ctx, target)
        if goal is not None:
            body = scene.pos(obj)
            bottom = float(scene.aabb(obj)[0][2])
            shift = np.array([goal[0] - body[0], goal[1] - body[1], goal[2] - bottom])

    def excess(g) -> float:
        here = float(np.linalg.norm(g.pos - shoulder)) - COMFORTABLE_REACH
        there = float(np.linalg.norm(g.pos + shift - shoulder)) - PLACING_REACH if shift is not None else 0.0
        if here < -CLOSE_AT_HAND:
            # Taken close at hand, the arm has room left to stretch out over the target: a bowl
            # on the stove (libero_spatial/7) held by its side rim reached the plate 0.79 m out,
            # where its near rim, ranked first by this rule, was missed again and again.
            there = 0.0
        return max(here, there, 0.0)

    if not grasps or all(excess(g) == 0.0 for g in grasps):
        return grasps
    # Reach re-ranks the grasps as deep as the best one only: traded against everything, it
    # put shallow chords across a bowl's near edge first (libero_spatial/2 and /3: every first
    # grasp missed and the pick planned again). Scores come back with the reach cost in them,
    # so a pick's choice among grasps as good as the first (its variety) stays within reach
    # too; the shallower grasps follow, scoring below them all.
    deepest = float(grasps[0].pos[2]) + SAME_DEPTH
    near_best = grasps[0].score - REACH_MARGIN
    deep = [
        replace(g, score=g.score - excess(g) / 0.01)
        for g in grasps
        if g.pos[2] <= deepest and g.score > near_best
    ]
    shallow = [
        replace(g, score=g.score - excess(g) / 0.01)
        for g in grasps
        if g.pos[2] > deepest or g.score <= near_best
    ]
    deep.sort(key=lambda g: -g.score)
    floor = deep[-1].score - GOOD_MARGIN
    shallow = [replace(g, score=min(g.score, floor)) for g in sorted(shallow, key=lambda g: -g.score)]
    return deep + shallow


def _target_point(ctx: Context, target: str) -> np.ndarray | None:
    """Where an object put on or into ``target`` ends up, roughly.

    An object target: its body's xy, 1 cm above its bottom (a plate's surface). A region:
    its site.
    """
    scene = ctx.scene
    if ctx.is_entity(target):
        bottom = float(scene.aabb(target)[0][2])
        return np.array([*scene.pos(target)[:2], bottom + 0.01])
    if scene.has_site(target):
        return scene.site(target).pos.copy()
    return None


def _for_side_insertion(ctx: Context, obj: str, grasps: list) -> list:
    """Re-rank grasps for carrying the object into a covered space from the side.

    The hand must stay outside while the object goes in: grasps far from the object's
    centre (a mug's handle) with the fingers closing across that offset come first.
    """
    com = ctx.scene.com(obj)[:2]
    if grasps:  # as deep as the best grasp only: a shallow rim grasp slips
        deepest = min(g.pos[2] for g in grasps)
        grasps = [g for g in grasps if g.pos[2] <= deepest + 0.004]

    def score(g) -> float:
        offset = g.pos[:2] - com
        reach = float(np.linalg.norm(offset))
        closing = g.mat[:2, 0] / max(float(np.linalg.norm(g.mat[:2, 0])), 1e-9)
        tangential = 1.0 - abs(float(offset @ closing)) / max(reach, 1e-9)
        return reach / 0.01 + 3.0 * tangential + 0.2 * g.score

    return sorted(grasps, key=lambda g: -score(g))
