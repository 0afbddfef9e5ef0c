"""Carrying a held object: clearance over obstacles, wrist turns, and setting it down."""

from __future__ import annotations

import numpy as np

from libero_data.experts.geometry import rot_z, rotation_error, yaw_of_closing
from libero_data.experts.motion import OPEN, SLOW_BELOW, Actions
from libero_data.experts.skills.base import Context, SkillFailed, lift

MAX_EEF_HEIGHT_ABOVE_TABLE = 0.55
#: Before lowering, wait at most this many steps for the held object to swing less than
#: ``SWINGING`` m/s: the lowering follows the object itself, so only a swing that would carry it
#: off the spot needs waiting out (held still to 2 cm/s, bowls waited ~11 steps on every place).
SETTLE_STEPS = 8
SWINGING = 0.05


#: Free-space speed (m/s of the set-point) for an object held by a thin rim.
GENTLE = 0.24


def held_offset(ctx: Context) -> tuple[np.ndarray, float]:
    """Object body position in the gripper frame, and how far its bottom hangs below the body."""
    assert ctx.held is not None
    scene = ctx.scene
    rel = scene.eef_mat().T @ (scene.pos(ctx.held) - scene.eef_pos())
    pts = scene.points(ctx.held)
    hang = float(scene.pos(ctx.held)[2] - pts[:, 2].min())
    return rel, hang


def footprint(ctx: Context, mat: np.ndarray) -> np.ndarray:
    """The held object's xy outline relative to its body, after turning the gripper to ``mat``."""
    assert ctx.held is not None
    scene = ctx.scene
    pts = scene.points(ctx.held)
    body = scene.pos(ctx.held)
    turn = mat @ scene.eef_mat().T
    rel = (pts - body) @ turn.T
    return rel[:, :2]


def best_turn(ctx: Context, base: np.ndarray, yaws: list[float]) -> np.ndarray:
    """Of the wrist yaws, the gripper orientation that turns least from now."""
    cur = ctx.scene.eef_mat()
    options = [rot_z(y) @ base for y in yaws]
    return min(options, key=lambda m: float(np.linalg.norm(rotation_error(m, cur))))


def carry_to(
    ctx: Context,
    body_xy: np.ndarray,
    bottom_z: float,
    mat: np.ndarray | None = None,
    *,
    exclude: tuple[str, ...] = (),
    above: float = 0.0,
) -> Actions:
    """Carry the held object until its body is over ``body_xy`` with its bottom at ``bottom_z``.

    The object is raised over everything on the way (with a margin), turned to ``mat`` on
    the way, and lowered straight down; ``above`` stops it that much higher.
    """
    assert ctx.held is not None
    ctx.phase = "transport"
    scene = ctx.scene
    mat = scene.eef_mat() if mat is None else mat
    rel, hang = held_offset(ctx)
    eef_xy = np.asarray(body_xy[:2]) - (mat @ rel)[:2]
    start = scene.eef_pos()
    radius = float(np.linalg.norm(footprint(ctx, mat), axis=1).max()) + 0.04
    obstacles = ctx.clear_height(start, eef_xy, (ctx.held, *exclude), radius)
    body_above_bottom = hang
    # grip-site height at which the object's bottom clears the obstacles
    clear = obstacles + 0.04 + body_above_bottom - (mat @ rel)[2]
    target_z = bottom_z + body_above_bottom - (mat @ rel)[2] + above
    travel = max(clear, target_z + 0.05, start[2])
    travel = min(travel, ctx.table_height() + MAX_EEF_HEIGHT_ABOVE_TABLE)
    if start[2] < travel - 0.01 and (yield from out_from_under(ctx, exclude)):
        start = scene.eef_pos()
    if start[2] < travel - 0.01:
        # Rise only as high as it takes for a straight line from there up to the travel height
        # over the target to clear everything on the way: the hand rises and travels at once.
        rise = _diagonal_start(
            ctx, start, eef_xy, travel, body_above_bottom - (mat @ rel)[2], radius, exclude
        )
        if rise > start[2] + 0.005:
            yield from lift(ctx, rise, speed=0.3 if ctx.notes.get("grasp_width", 1.0) >= 0.012 else 0.15)
    # A thin rim between the fingers slips under fast turns and stops: carry it gently.
    gentle = GENTLE if ctx.notes.get("grasp_width", 1.0) < 0.012 else None
    # When only the start of the way needs the height (a bowl carried off a cabinet top),
    # come down as soon as the rest is clear: a far target is out of the stretched arm's
    # reach high up, and within it lower down.
    for f in (0.3, 0.5, 0.7):
        partway = start[:2] + f * (eef_xy - start[:2])
        rest = ctx.clear_height(partway, eef_xy, (ctx.held, *exclude), radius)
        lower = max(rest + 0.04 + body_above_bottom - (mat @ rel)[2], target_z + 0.05)
        if lower < travel - 0.05:
            yield from ctx.motion.move(
                np.array([partway[0], partway[1], travel]), mat, speed=gentle, tol=0.02, max_steps=100
            )
            travel = lower
            break
    yield from ctx.motion.move(
        np.array([eef_xy[0], eef_xy[1], travel]), mat, speed=gentle, tol=0.012, max_steps=200
    )
    if not scene.grasped(ctx.held):
        raise SkillFailed(f"dropped {ctx.held} while carrying it")
    # An object held off its centre (by a handle) may have swung in the hand: let it settle,
    # then lower it closed loop on where the object itself is, not where it was.
    for _ in range(SETTLE_STEPS):
        if scene.speed(ctx.held) < SWINGING:
            break
        yield from ctx.motion.hold(1, mat)
    speed = 0.12 + ctx.jitter(0.03)
    ctx.phase = "lower"
    # Line up over the spot before going down: a narrow slot leaves a few mm to the walls.
    for _ in range(20):
        error_xy = np.asarray(body_xy[:2]) - scene.pos(ctx.held)[:2]
        if np.linalg.norm(error_xy) < 0.003:
            break
        goal = scene.eef_pos() + np.array([error_xy[0], error_xy[1], 0.0])
        yield from ctx.motion.move(goal, mat, speed=speed, tol=0.002, max_steps=2, gain=1.0)
    trail: list[np.ndarray] = []
    for _ in range(80):
        body = scene.pos(ctx.held)
        bottom = float(scene.points(ctx.held)[:, 2].min())
        error_xy = np.asarray(body_xy[:2]) - body[:2]
        error_z = (bottom_z + above) - bottom
        # There, and not still moving down (let go at 4 cm/s, a bowl hops off a plate's rim).
        if np.linalg.norm(error_xy) < 0.005 and abs(error_z) < 0.006 and scene.speed(ctx.held) < 0.02:
            return True
        # Resting on something short of the spot (the table a little higher than planned):
        # pressing on does not bring it closer. Stop once 12 steps moved it less than 1 mm.
        trail.append(np.array([body[0], body[1], bottom]))
        if len(trail) > 6 and float(np.linalg.norm(trail[-1] - trail[-7])) < 0.001:
            return False
        goal = scene.eef_pos() + np.array([error_xy[0], error_xy[1], error_z])
        # Down at twice the pace while the object is still well above where it goes.
        pace = 2.0 * speed if error_z < -SLOW_BELOW else speed
        yield from ctx.motion.move(goal, mat, speed=pace, tol=0.003, max_steps=2, gain=1.0)
    return False


def _diagonal_start(
    ctx: Context,
    start: np.ndarray,
    end_xy: np.ndarray,
    travel: float,
    grip_above_bottom: float,
    radius: float,
    exclude: tuple[str, ...],
) -> float:
    """The lowest grip-site height over ``start`` from which the straight line to ``end_xy`` at
    the ``travel`` height keeps the held object's bottom 4 cm above what lies near the way."""
    assert ctx.held is not None
    pts = ctx.scene.obstacle_points(exclude=(ctx.held, *exclude))
    a, b = np.asarray(start[:2]), np.asarray(end_xy[:2])
    near = _distance_to_segment(pts[:, :2], a, b) < radius + 0.02
    pts = pts[near]
    if not len(pts):
        return float(start[2])
    fractions = np.linspace(0.0, 1.0, 13)
    heights = []
    for f in fractions:
        xy = a + f * (b - a)
        close = np.linalg.norm(pts[:, :2] - xy, axis=1) < radius
        heights.append(float(pts[close, 2].max()) if close.any() else -np.inf)
    floor = np.asarray(heights) + 0.04 + grip_above_bottom
    for z0 in [*np.arange(float(start[2]), travel, 0.02), travel]:
        if np.all(z0 + fractions * (travel - z0) >= floor):
            return float(z0)
    return float(travel)


def _distance_to_segment(xy: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    ab = b - a
    t = np.clip(((xy - a) @ ab) / max(float(ab @ ab), 1e-9), 0.0, 1.0)
    return np.linalg.norm(xy - (a + t[:, None] * ab), axis=1)


def out_from_under(ctx: Context, exclude: tuple[str, ...] = ()) -> Actions:
    """Slide the held object sideways until nothing hangs over it (a bowl taken by its free side
    from under an open drawer); False when nothing did. Straight up, it would hit what is above."""
    assert ctx.held is not None
    scene = ctx.scene
    lo, hi = scene.aabb(ctx.held)
    pts = scene.obstacle_points(exclude=(ctx.held, *exclude))
    pts = pts[(pts[:, 2] > hi[2]) & (pts[:, 2] < hi[2] + 0.3)]

    def over(shift: np.ndarray) -> np.ndarray:
        inside = np.all((pts[:, :2] > lo[:2] + shift - 0.015) & (pts[:, :2] < hi[:2] + shift + 0.015), axis=1)
        return pts[inside]

    overhang = over(np.zeros(2))
    if not len(overhang):
        return False
    away = (lo[:2] + hi[:2]) / 2 - overhang[:, :2].mean(0)
    away /= max(float(np.linalg.norm(away)), 1e-9)
    for distance in np.arange(0.02, 0.16, 0.01):
        if not len(over(away * distance)):
            goal = scene.eef_pos() + np.array([*(away * (distance + 0.01)), 0.0])
            yield from ctx.motion.move(goal, scene.eef_mat(), tol=0.01, max_steps=40)
            return True
    return False


def release(ctx: Context, rise: float = 0.08) -> Actions:
    """Open the gripper and move up out of the way."""
    ctx.phase = "release"
    mat = ctx.scene.eef_mat()
    yield from ctx.motion.set_gripper(OPEN, steps=8, mat=mat)
    ctx.held = None
    yield from lift(ctx, ctx.scene.eef_pos()[2] + rise + ctx.jitter(0.02), mat, speed=0.25)
    return True


def wrist_options(ctx: Context) -> list[float]:
    """Yaw turns to consider when setting an object down (the wrist's range is limited)."""
    del ctx
    return [k * np.pi / 8 for k in range(-8, 9)]


def yaw_now(ctx: Context) -> float:
    return yaw_of_closing(ctx.scene.eef_mat())
