"""Place in: put the held object into a container region (basket, tray, drawer, caddy...)."""

from __future__ import annotations

import logging

import numpy as np

from libero_data.experts.motion import Actions
from libero_data.experts.scene import Site
from libero_data.experts.skills.base import SKILLS, Context, Skill, SkillFailed, turn_wrist
from libero_data.experts.skills.carry import (
    best_turn,
    carry_to,
    footprint,
    held_offset,
    release,
    wrist_options,
)
from libero_data.experts.skills.insert import insert_from_side, is_enclosed, region_box

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
        if is_enclosed(ctx, site):
            return (yield from insert_from_side(ctx, site, region))
        mat = _fitting_orientation(ctx, site)
        spot = _open_spot(ctx, site, mat, container)
        if spot is None:
            raise SkillFailed(f"no open spot in {region} for {obj}")
        xy, floor = spot
        if floor + held_offset(ctx)[1] > region_box(site)[1][2] - 0.003:
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
    lo, hi = region_box(site)
    outline = footprint(ctx, mat)
    spare = (hi - lo)[:2] / 2 - (outline.max(0) - outline.min(0)) / 2
    return bool(spare.min() < 0.015)


def _wall_top(ctx: Context, site: Site, xy: np.ndarray) -> float:
    """Top of what stands around the drop spot (walls, dividers), within 15 cm of it."""
    hi = region_box(site)[1]
    pts = ctx.scene.obstacle_points(exclude=(ctx.held,) if ctx.held else ())
    near = np.linalg.norm(pts[:, :2] - xy, axis=1) < 0.15
    return float(pts[near, 2].max()) if near.any() else float(hi[2])


def _lay_down(ctx: Context, site: Site, mat: np.ndarray, xy: np.ndarray, floor: float) -> Actions:
    """Stand the held object at one end of the region, then tip it over along the region."""
    assert ctx.held is not None
    scene = ctx.scene
    lo, hi = region_box(site)
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


def _fitting_orientation(ctx: Context, site: Site) -> np.ndarray:
    """Wrist orientation whose object outline fits the region's rectangle best.

    Besides the wrist's regular steps, the turns that square the object's outline with the
    box are tried (a book into a narrow caddy slot fits only square to it). An outline that
    overflows the box costs most; one with less than 1 cm to spare on a side comes next
    (the box is LIBERO's region, the walls stand at its edge); turning far costs least.
    """
    lo, hi = region_box(site)
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
    lo, hi = region_box(site)
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
