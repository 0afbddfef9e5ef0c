"""Inserting the held object into a region covered from above (a shelf layer, a microwave):
carried in through the open side, slid in with the hand pointing in, or laid in front of a
low layer and dragged in."""

from __future__ import annotations

import logging

import numpy as np

from libero_data.experts.geometry import approach_frame
from libero_data.experts.grasp import hand_collisions
from libero_data.experts.motion import OPEN, Actions
from libero_data.experts.scene import Site
from libero_data.experts.skills.base import Context, SkillFailed, lift, turn_wrist
from libero_data.experts.skills.carry import (
    carry_to,
    footprint,
    held_offset,
)

log = logging.getLogger(__name__)


def region_box(site: Site) -> tuple[np.ndarray, np.ndarray]:
    """World-axis-aligned half extents of a region, as LIBERO's ``in_box`` computes them."""
    half = np.abs(site.mat @ site.size)
    return site.pos - half, site.pos + half


def is_enclosed(ctx: Context, site: Site) -> bool:
    """Whether most of the region's box is covered from above (a microwave, a shelf layer)."""
    lo, hi = region_box(site)
    pts = ctx.scene.obstacle_points(exclude=(ctx.held,) if ctx.held else ())
    inside = np.all(
        (pts[:, :2] > lo[:2] + 0.1 * (hi - lo)[:2]) & (pts[:, :2] < hi[:2] - 0.1 * (hi - lo)[:2]), axis=1
    )
    # A cover lies above the region, clear of its floor (a thin region such as a cabinet's
    # top side is not covered by the surface it marks).
    floor = max(hi[2] - 0.005, lo[2] + 0.03)
    above = pts[inside & (pts[:, 2] > floor) & (pts[:, 2] < hi[2] + 0.12)]
    if len(above) == 0:
        return False
    cells = set(
        map(tuple, np.floor((above[:, :2] - lo[:2]) / np.maximum((hi - lo)[:2] / 5, 1e-3)).astype(int))
    )
    return len(cells) >= 0.6 * 25


def _entrance(ctx: Context, site: Site) -> np.ndarray:
    """The horizontal direction out of the region through its most open side.

    Each side is cut into cells (across x height); a cell is blocked when anything lies at
    or up to 10 cm beyond the side (a wall may stand a little outside the region's box).
    """
    lo, hi = region_box(site)
    centre, half = (lo + hi) / 2, (hi - lo) / 2
    pts = ctx.scene.obstacle_points(exclude=(ctx.held,) if ctx.held else ())
    rel = pts - centre
    best, best_open = None, -1.0
    for angle in np.arange(8) * np.pi / 4:
        d = np.array([np.cos(angle), np.sin(angle)])
        side = np.array([-d[1], d[0]])
        extent = float(np.abs(d) @ half[:2])
        width = float(np.abs(side) @ half[:2])
        along, across = rel[:, :2] @ d, rel[:, :2] @ side
        band = (along > extent - 0.03) & (along < extent + 0.10) & (np.abs(across) < width)
        band &= (rel[:, 2] > -0.8 * half[2]) & (rel[:, 2] < 0.8 * half[2])
        cols = np.clip(((across[band] / width + 1) / 2 * 8).astype(int), 0, 7)
        rows = np.clip(((rel[band, 2] / (0.8 * half[2]) + 1) / 2 * 4).astype(int), 0, 3)
        blocked = len(set(zip(cols.tolist(), rows.tolist(), strict=True)))
        opened = 1.0 - blocked / 32
        if opened > best_open:
            best, best_open = d, opened
    assert best is not None
    return best


def insert_from_side(ctx: Context, site: Site, region: str) -> Actions:
    """Carry the object in through the region's open side, the hand top down on the
    entrance side of it; where that hand does not fit (a book too tall for a shelf layer
    with the hand above it), tip the hand to point in, the object held ahead of it."""
    assert ctx.held is not None
    scene = ctx.scene
    obj = ctx.held
    hi = region_box(site)[1]
    out = _entrance(ctx, site)
    # Turn the wrist so the hand (the grasp) is on the entrance side of the object.
    grip_rel = scene.eef_pos()[:2] - scene.pos(obj)[:2]
    turn = float(np.arctan2(out[1], out[0]) - np.arctan2(grip_rel[1], grip_rel[0]))
    yield from lift(ctx, max(scene.eef_pos()[2], hi[2] + 0.1))
    yield from turn_wrist(ctx, turn)
    slide = _slide_in_pose(ctx, site, out)
    if slide is None and _lower_when_tipped(ctx, site):
        yield from _point_in(ctx, out, hi[2] + 0.15)
        slide = _slide_in_pose(ctx, site, out)
    elif slide is None and _thin_enough(ctx, site):
        yield from _point_in(ctx, out, hi[2] + 0.15)
        return (yield from _lay_in_front(ctx, site, out))
    if slide is None:
        raise SkillFailed(f"the hand does not fit into {region}")
    return (yield from _slide_in(ctx, out, *slide))


def _thin_enough(ctx: Context, site: Site) -> bool:
    """Whether the held object, laid on the side the fingers pinch, is lower than the region
    is tall (a book under a 7-cm shelf layer: 2.4 cm lying flat)."""
    assert ctx.held is not None
    pts = ctx.scene.points(ctx.held)
    lo, hi = region_box(site)
    return float(np.ptp(pts @ ctx.scene.eef_mat()[:, 0])) + 0.01 < float(hi[2] - lo[2])


#: Nose-down tilt (deg) at which a held flat object touches the table with its far end while
#: the 21-cm hand, fingers one above the other, stays clear of the table.
NOSE_DOWN = 38.0


def _lay_in_front(ctx: Context, site: Site, out: np.ndarray) -> Actions:
    """Lay the object flat on the table just in front of a low layer and slide it in.

    The hand, level and pointing in (:func:`_point_in`), rolls a quarter turn so the fingers
    pinch the object from above and below, tips nose down until its far end touches the
    table 1.5 cm short of the entrance, and lets go: the object settles flat. The hand then
    moves on in, the lower finger under the object dragging it through the entrance, and
    leaves sideways. Made for libero_90/89 (a book under a shelf); how often it succeeds there
    over 50 stored init states is in the expert report (cards/expert_report.md). Randomised:
    the drag length.
    """
    assert ctx.held is not None
    scene = ctx.scene
    obj = ctx.held
    inward = np.array([-out[0], -out[1], 0.0])
    across = np.array([-out[1], out[0], 0.0])
    here = scene.eef_pos()
    start = scene.eef_mat()
    for k in range(1, 4):  # the roll, in 30-degree steps
        turn = np.deg2rad(30.0 * k)
        closing = start[:, 0] * np.cos(turn) + start[:, 1] * np.sin(turn)
        yield from ctx.motion.move(
            here, approach_frame(start[:, 2], closing), tol=0.02, rot_tol=0.1, max_steps=30
        )
    rolled = scene.eef_mat()[:, 0]
    down = np.array([0.0, 0.0, -1.0])
    for k in range(1, 4):  # nose down, in three steps
        tilt = np.deg2rad(NOSE_DOWN * k / 3)
        approach = inward * np.cos(tilt) + down * np.sin(tilt)
        closing = rolled - approach * (rolled @ approach)
        yield from ctx.motion.move(
            here, approach_frame(approach, closing), tol=0.02, rot_tol=0.1, max_steps=30
        )
    mat = scene.eef_mat()
    lo, hi = region_box(site)
    centre, half = (lo + hi) / 2, (hi - lo) / 2
    face = centre[:2] + out[:2] * float(np.abs(out[:2]) @ half[:2])
    pts, eef = scene.points(obj), scene.eef_pos()
    ahead = float(((pts[:, :2] - eef[:2]) @ inward[:2]).max())
    below = float(eef[2] - pts[:, 2].min())
    target = np.array([*(face + out[:2] * (ahead + 0.015)), ctx.table_height() + below - 0.005])
    target[:2] += across[:2] * float((centre[:2] - face) @ across[:2])  # mid-way across
    yield from ctx.motion.move(target + np.array([0.0, 0.0, 0.06]), mat, tol=0.01, max_steps=150)
    yield from ctx.motion.move(target, mat, speed=0.08, tol=0.006, max_steps=60)
    yield from ctx.motion.set_gripper(OPEN, steps=8, mat=mat)
    ctx.held = None
    yield from ctx.motion.hold(6, mat)
    # Either stroke may end against something (the far wall, the side): then on to the next.
    yield from ctx.motion.move(
        scene.eef_pos() + inward * (0.06 + ctx.jitter(0.005)),
        mat,
        speed=0.05,
        tol=0.008,
        max_steps=40,
        stall=6,
    )
    yield from ctx.motion.move(
        scene.eef_pos() + across * 0.1, mat, speed=0.08, tol=0.01, max_steps=40, stall=6
    )
    yield from lift(ctx, scene.eef_pos()[2] + 0.06)
    return True


def _lower_when_tipped(ctx: Context, site: Site) -> bool:
    """Whether tipping the hand level would leave the held object lower than it stands now,
    and lower than the region is tall (a book pinched across its thickness: its width
    becomes its height). A pan held by its handle would only stand taller."""
    assert ctx.held is not None
    scene = ctx.scene
    pts = scene.points(ctx.held)
    lo, hi = region_box(site)
    # Tipping about the closing axis turns the hand's other horizontal axis upright.
    tipped = float(np.ptp(pts @ scene.eef_mat()[:, 1]))
    return tipped < float(np.ptp(pts[:, 2])) and tipped + 0.01 < float(hi[2] - lo[2])


def _point_in(ctx: Context, out: np.ndarray, height: float) -> Actions:
    """Tip the hand, object held, from top down to level and pointing against ``out``.

    First the wrist turns the fingers' closing axis across the way in, then the hand tips in
    15-degree steps in place, so the object turns about its grasp without swinging.
    """
    assert ctx.held is not None
    scene = ctx.scene
    yield from lift(ctx, height)
    across = np.array([-out[1], out[0], 0.0])
    inward = np.array([-out[0], -out[1], 0.0])
    closing = scene.eef_mat()[:, 0]
    yaw_now = float(np.arctan2(closing[1], closing[0]))
    turn = (float(np.arctan2(across[1], across[0])) - yaw_now + np.pi / 2) % np.pi - np.pi / 2
    # Tipping turns "beyond the object's middle, inward" into "above it": a grasp off the
    # middle must end up on the upper side, or the hand hangs below the object and hits the
    # floor it is slid along. Half a turn more puts it there.
    offset = scene.eef_pos()[:2] - scene.points(ctx.held)[:, :2].mean(0)
    c, s = np.cos(turn), np.sin(turn)
    if (np.array([[c, -s], [s, c]]) @ offset) @ inward[:2] < 0:
        turn += np.pi
    yield from turn_wrist(ctx, turn)
    closing = scene.eef_mat()[:, 0]
    closing = across if closing @ across >= 0 else -across
    down = np.array([0.0, 0.0, -1.0])
    here = scene.eef_pos()
    for k in range(1, 7):
        tilt = np.deg2rad(90.0 - 15.0 * k)
        mat = approach_frame(inward * np.cos(tilt) + down * np.sin(tilt), closing)
        yield from ctx.motion.move(here, mat, tol=0.02, rot_tol=0.1, max_steps=30)
    return True


def _slide_in_pose(
    ctx: Context, site: Site, out: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, float, float] | None:
    """Where the grip site goes to leave the object deepest in the region with the hand as it
    is now: (eef target, gripper orientation, face point, bottom height, reach ahead), or None
    when the hand and object fit nowhere."""
    assert ctx.held is not None
    scene = ctx.scene
    obj = ctx.held
    lo, hi = region_box(site)
    centre, half = (lo + hi) / 2, (hi - lo) / 2
    face = centre[:2] + out * float(np.abs(out) @ half[:2])
    mat = scene.eef_mat()
    rel, hang = held_offset(ctx)
    body_to_eef = -(mat @ rel)
    others = scene.obstacle_points(exclude=(obj,))
    near = np.linalg.norm(others[:, :2] - centre[:2], axis=1) < 0.5
    others = others[near]
    outline = footprint(ctx, mat)
    shrink = 0.15 * (hi - lo)[:2]
    inner = np.all((others[:, :2] > lo[:2] + shrink) & (others[:, :2] < hi[:2] - shrink), axis=1)
    inner &= others[:, 2] < lo[2] + 0.03
    floor = float(others[inner, 2].max()) if inner.any() else float(lo[2])
    bottom = floor + 0.012 + ctx.jitter(0.003)
    body_z = bottom + hang
    depth_max = float(np.abs(out) @ (2 * half[:2]))
    # How far the object reaches ahead of its body into the region (a pan held by its
    # handle reaches in with its pan only; the handle stays out, and In checks the body).
    reach_in = float(max(-(outline @ out).min(), 0.0))
    chosen = None
    opening = scene.finger_opening()
    side = np.array([-out[1], out[0]])
    width = float(np.abs(side) @ half[:2])
    shifts = sorted(np.linspace(-0.8 * width, 0.8 * width, 17), key=abs)
    # The object itself must fit too: a wide pan slid in off-centre catches on a side wall.
    from scipy.spatial import cKDTree

    walls = cKDTree(others) if len(others) else None
    shape = scene.points(obj) - scene.pos(obj)
    for depth in np.arange(depth_max - reach_in, 0.0, -0.005):
        for shift in shifts:
            body = np.array([*(face - out * depth + side * shift), body_z])
            eef = body + body_to_eef
            if hand_collisions(others, eef, mat, opening=opening, margin=0.004) != 0:
                continue
            if (
                walls is not None
                and np.isfinite(walls.query(shape + body, distance_upper_bound=0.006)[0]).any()
            ):
                continue
            chosen = (body, eef)
            break
        if chosen is not None:
            break
    if chosen is None:
        log.debug("insert: out=%s face=%s body_to_eef=%s floor=%.3f", out, face, body_to_eef, floor)
        return None
    return chosen[1], mat, face, bottom, reach_in


def _slide_in(
    ctx: Context,
    out: np.ndarray,
    eef: np.ndarray,
    mat: np.ndarray,
    face: np.ndarray,
    bottom: float,
    reach_in: float,
) -> Actions:
    """Bring the object level with the entrance, slide it in to ``eef``, let go, back out."""
    assert ctx.held is not None
    scene = ctx.scene
    body = scene.pos(ctx.held) + (eef - scene.eef_pos())
    outside = body[:2] + out * (float(np.linalg.norm(body[:2] - face)) + reach_in + 0.06)
    yield from carry_to(ctx, outside, bottom, mat)
    # A long-handled object lowered fast swings in the hand: let it come to rest first, or
    # it goes into the opening askew and high and the slide stops short.
    for _ in range(20):
        if scene.speed(ctx.held) < 0.02:
            break
        yield from ctx.motion.hold(1, mat)
    # About 3 mm per step at this speed: allow for the whole way in (a long-handled pan
    # starts far out).
    way = float(np.linalg.norm(scene.eef_pos() - eef))
    budget, goal = max(80, int(40 + way / 0.0025)), eef.copy()
    for _ in range(0, budget, 4):
        # An object held by its handle sags: its far edge drags on the floor of the opening
        # and catches there. Raise the hand by what the object's lowest point has sunk
        # below the planned clearance (at most 5 cm).
        sunk = (bottom - 0.008) - float(scene.points(ctx.held)[:, 2].min())
        if sunk > 0:
            goal[2] = min(max(goal[2], scene.eef_pos()[2] + sunk), eef[2] + 0.05)
        if (yield from ctx.motion.move(goal, mat, speed=0.1, tol=0.006, max_steps=4)):
            break
    yield from ctx.motion.set_gripper(OPEN, steps=8, mat=mat)
    ctx.held = None
    inside = max(float((face - scene.eef_pos()[:2]) @ out), 0.0)  # how deep the hand went in
    back = scene.eef_pos() + np.array([*(out * (inside + 0.08)), 0.0])
    yield from ctx.motion.move(back, mat, speed=0.15, tol=0.015, max_steps=60)
    yield from lift(ctx, scene.eef_pos()[2] + 0.08)
    return True
