"""Place in: put the held object into a container region (basket, tray, drawer, caddy...)."""

from __future__ import annotations

import logging

import numpy as np

from libero_data.experts.geometry import approach_frame
from libero_data.experts.grasp import hand_collisions
from libero_data.experts.motion import OPEN, Actions
from libero_data.experts.scene import Site
from libero_data.experts.skills.base import SKILLS, Context, Skill, SkillFailed, lift, turn_wrist
from libero_data.experts.skills.carry import (
    best_turn,
    carry_to,
    footprint,
    held_offset,
    release,
    wrist_options,
)

log = logging.getLogger(__name__)


@SKILLS.register("place_in")
class PlaceIn(Skill):
    """``place_in(obj, region)``: put the object into the region and let go.

    LIBERO's ``In`` holds when the object's body lies inside the region's box. Open from
    above (baskets, trays, caddies, drawers): the drop point is the spot of the box whose
    column is open for the object's outline (a drawer pulled out is open only at its
    front), and the wrist turns the object so its outline fits the box. Covered from above
    (a microwave, a shelf's lower layer): the object is carried in from the open side, the
    hand leading from that side, as deep as the hand fits; where a hand above the object
    does not fit (a book into a shelf layer hardly taller than it), the hand tips level and
    slides the object in ahead of it. Randomised: the spot among the
    open ones, release height, insertion depth.
    """

    name = "place_in"

    def run(self, ctx: Context) -> Actions:
        obj, region = self.args
        if ctx.held != obj:
            raise SkillFailed(f"place_in({obj}) without holding it")
        scene = ctx.scene
        site = scene.site(region)
        container = ctx.parent_of(region)
        if _enclosed(ctx, site):
            return (yield from _insert_from_side(ctx, site, region))
        mat = _fitting_orientation(ctx, site)
        spot = _open_spot(ctx, site, mat, container)
        if spot is None:
            raise SkillFailed(f"no open spot in {region} for {obj}")
        xy, floor = spot
        if floor + held_offset(ctx)[1] > _box(site)[1][2] - 0.003:
            # Standing up, its body would stay above the region's box (a ketchup bottle in a
            # shallow drawer): set it down at one end and tip it over onto its side.
            return (yield from _lay_down(ctx, site, mat, xy, floor))
        if _narrow(ctx, site, mat):
            # A few mm to spare (a book into a caddy slot): stop above the walls, look how the
            # object really hangs in the hand (it may have turned a little), square it again.
            walls = _wall_top(ctx, site, xy)
            yield from carry_to(ctx, xy, floor + 0.015, mat, above=max(walls - floor, 0.0) + 0.02)
            residual = _outline_angle(footprint(ctx, scene.eef_mat()))
            residual = residual if residual < np.pi / 4 else residual - np.pi / 2
            if abs(residual) > np.deg2rad(1.5):
                yield from turn_wrist(ctx, -residual)
                mat = scene.eef_mat()
                xy, floor = _open_spot(ctx, site, mat, container) or (xy, floor)
        yield from carry_to(ctx, xy, floor + 0.015 + ctx.jitter(0.005), mat)
        yield from release(ctx)
        return True


def _narrow(ctx: Context, site: Site, mat: np.ndarray) -> bool:
    """Whether the held object's outline leaves less than 1.5 cm of the region on a side."""
    lo, hi = _box(site)
    outline = footprint(ctx, mat)
    spare = (hi - lo)[:2] / 2 - (outline.max(0) - outline.min(0)) / 2
    return bool(spare.min() < 0.015)


def _wall_top(ctx: Context, site: Site, xy: np.ndarray) -> float:
    """Top of what stands around the drop spot (walls, dividers), within 15 cm of it."""
    hi = _box(site)[1]
    pts = ctx.scene.obstacle_points(exclude=(ctx.held,) if ctx.held else ())
    near = np.linalg.norm(pts[:, :2] - xy, axis=1) < 0.15
    return float(pts[near, 2].max()) if near.any() else float(hi[2])


def _lay_down(ctx: Context, site: Site, mat: np.ndarray, xy: np.ndarray, floor: float) -> Actions:
    """Stand the held object at one end of the region, then tip it over along the region."""
    assert ctx.held is not None
    scene = ctx.scene
    lo, hi = _box(site)
    pts = scene.points(ctx.held)
    height = float(pts[:, 2].max() - pts[:, 2].min())
    radius = float(np.abs(footprint(ctx, mat)).max())
    # Tip along the region's longer side, towards whichever end is farther from the spot.
    axis = int(np.argmax((hi - lo)[:2]))
    d = np.zeros(2)
    d[axis] = 1.0 if hi[axis] - xy[axis] >= xy[axis] - lo[axis] else -1.0
    start_end, far_end = (lo[axis], hi[axis]) if d[axis] > 0 else (-hi[axis], -lo[axis])
    along = float(xy @ d)
    along = min(along, far_end - 0.95 * height)
    along = max(along, start_end + radius + 0.01)
    body = xy.copy()
    body[axis] = along * d[axis]
    yield from carry_to(ctx, body, floor + 0.008, mat)
    tip = scene.eef_pos() + np.array([*(d * 0.5 * height), -0.3 * height])
    yield from ctx.motion.move(tip, mat, speed=0.15, tol=0.01, max_steps=50)
    yield from release(ctx)
    return True


def _box(site: Site) -> tuple[np.ndarray, np.ndarray]:
    """World-axis-aligned half extents of a region, as LIBERO's ``in_box`` computes them."""
    half = np.abs(site.mat @ site.size)
    return site.pos - half, site.pos + half


def _fitting_orientation(ctx: Context, site: Site) -> np.ndarray:
    """Wrist orientation whose object outline fits the region's rectangle best.

    Besides the wrist's regular steps, the turns that square the object's outline with the
    box are tried (a book into a narrow caddy slot fits only square to it). An outline that
    overflows the box costs most; one with less than 1 cm to spare on a side comes next
    (the box is LIBERO's region, the walls stand at its edge); turning far costs least.
    """
    lo, hi = _box(site)
    room = (hi - lo)[:2] / 2
    base = ctx.scene.eef_mat()
    best, best_cost = base, np.inf
    yaws = list(wrist_options(ctx))
    square = _outline_angle(footprint(ctx, base))
    yaws += [(-square + k * np.pi / 2 + np.pi) % (2 * np.pi) - np.pi for k in range(4)]
    for yaw in yaws:
        mat = best_turn(ctx, base, [yaw])
        outline = footprint(ctx, mat)
        extent = (outline.max(0) - outline.min(0)) / 2  # the drop spot centres the outline
        overflow = float(np.clip(extent - room, 0, None).sum())
        tight = float(np.clip(0.01 - (room - extent), 0, 0.01).max())
        turn = abs(yaw)
        cost = overflow * 100 + tight * 10 + turn * 0.01
        if cost < best_cost:
            best, best_cost = mat, cost
    return best


def _outline_angle(outline: np.ndarray) -> float:
    """Angle of an xy outline's long axis (of its smallest-area bounding rectangle), in [0, pi/2)."""
    best_area, best_angle = np.inf, 0.0
    for angle in np.linspace(0, np.pi / 2, 46, endpoint=False):
        c, s = np.cos(angle), np.sin(angle)
        rotated = outline @ np.array([[c, -s], [s, c]])
        area = float(np.prod(rotated.max(0) - rotated.min(0)))
        if area < best_area:
            best_area, best_angle = area, angle
    return best_angle


def _open_spot(ctx: Context, site: Site, mat: np.ndarray, container: str) -> tuple[np.ndarray, float] | None:
    """A point of the region whose column is free above the object's outline, and the floor there.

    The outline is the held object's footprint (turned as it will be), as a rectangle around
    the body position. Inside it: the floor is the highest point under the middle half;
    anything above the region's box over the outline (a cabinet over its drawer) rules the
    spot out; walls rising inside the outline are allowed only near its edge (rims). Best is
    the most room to the nearest walls beside it, then fewer rim points, then the centre.
    """
    assert ctx.held is not None
    scene = ctx.scene
    lo, hi = _box(site)
    outline = footprint(ctx, mat)
    omin, omax = outline.min(0), outline.max(0)
    mid, half = (omin + omax) / 2, (omax - omin) / 2
    reach = float(np.abs(outline).max()) + 0.02
    pts = scene.obstacle_points(exclude=(ctx.held,))
    local = pts[np.all((pts[:, :2] > lo[:2] - reach) & (pts[:, :2] < hi[:2] + reach), axis=1)]
    margin = 0.005
    xs = (
        np.linspace(lo[0] + margin, hi[0] - margin, 11)
        if hi[0] - lo[0] > 2 * margin
        else np.array([site.pos[0]])
    )
    ys = (
        np.linspace(lo[1] + margin, hi[1] - margin, 11)
        if hi[1] - lo[1] > 2 * margin
        else np.array([site.pos[1]])
    )
    candidates = []
    for x in xs:
        for y in ys:
            xy = np.array([x, y])
            rel = np.abs(local[:, :2] - (xy + mid)) / np.maximum(half, 1e-3)  # 1.0 = outline edge
            edge = rel.max(axis=1)
            base = (edge < 0.5) & (local[:, 2] < hi[2] + 0.005) & (local[:, 2] > lo[2] - 0.05)
            floor = float(local[base, 2].max()) if base.any() else float(lo[2])
            if floor > hi[2] - 0.01:
                continue
            if ((edge < 0.9) & (local[:, 2] > hi[2] + 0.02)).any():
                continue  # something overhead
            rising = local[:, 2] > floor + 0.03
            walls = (edge < 0.9) & rising
            if (walls & (edge < 0.6)).any():
                continue  # a wall through the middle of the outline, not just a rim at its edge
            # Room to the nearest wall beside the outline along x and along y (m), each
            # counted up to 1.5 cm: a narrow slot leaves a few mm, best shared on both sides.
            gap = np.abs(local[rising, :2] - (xy + mid)) - half
            room = sum(
                min(float(gap[gap[:, 1 - axis] < 0, axis].min(initial=0.015)), 0.015) for axis in (0, 1)
            )
            centre = float(np.linalg.norm(xy - site.pos[:2]))
            candidates.append((-room, int(walls.sum()), centre + float(ctx.rng.uniform(0, 0.01)), xy, floor))
    if not candidates:
        return None
    candidates.sort(key=lambda c: (c[0], c[1], c[2]))
    *_, xy, floor = candidates[0]
    return xy, floor


def _enclosed(ctx: Context, site: Site) -> bool:
    """Whether most of the region's box is covered from above (a microwave, a shelf layer)."""
    lo, hi = _box(site)
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
    lo, hi = _box(site)
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


def _insert_from_side(ctx: Context, site: Site, region: str) -> Actions:
    """Carry the object in through the region's open side, the hand top down on the
    entrance side of it; where that hand does not fit (a book too tall for a shelf layer
    with the hand above it), tip the hand to point in, the object held ahead of it."""
    assert ctx.held is not None
    scene = ctx.scene
    obj = ctx.held
    hi = _box(site)[1]
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
    lo, hi = _box(site)
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
    leaves sideways. On libero_90/89 (a book under a shelf) this worked from 9 of the first
    10 inits in development. Randomised: the drag length.
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
    lo, hi = _box(site)
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
    yield from ctx.motion.move(
        scene.eef_pos() + inward * (0.06 + ctx.jitter(0.005)), mat, speed=0.05, tol=0.008, max_steps=40
    )
    yield from ctx.motion.move(scene.eef_pos() + across * 0.1, mat, speed=0.08, tol=0.01, max_steps=40)
    yield from lift(ctx, scene.eef_pos()[2] + 0.06)
    return True


def _lower_when_tipped(ctx: Context, site: Site) -> bool:
    """Whether tipping the hand level would leave the held object lower than it stands now,
    and lower than the region is tall (a book pinched across its thickness: its width
    becomes its height). A pan held by its handle would only stand taller."""
    assert ctx.held is not None
    scene = ctx.scene
    pts = scene.points(ctx.held)
    lo, hi = _box(site)
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
    lo, hi = _box(site)
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
    # About 3 mm per step at this speed: allow for the whole way in (a long-handled pan
    # starts far out).
    way = float(np.linalg.norm(scene.eef_pos() - eef))
    yield from ctx.motion.move(eef, mat, speed=0.1, tol=0.006, max_steps=max(80, int(40 + way / 0.0025)))
    yield from ctx.motion.set_gripper(OPEN, steps=8, mat=mat)
    ctx.held = None
    inside = max(float((face - scene.eef_pos()[:2]) @ out), 0.0)  # how deep the hand went in
    back = scene.eef_pos() + np.array([*(out * (inside + 0.08)), 0.0])
    yield from ctx.motion.move(back, mat, speed=0.15, tol=0.015, max_steps=60)
    yield from lift(ctx, scene.eef_pos()[2] + 0.08)
    return True
