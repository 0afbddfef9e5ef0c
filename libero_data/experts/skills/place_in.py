"""Place in: put the held object into a container region (basket, tray, drawer, caddy...)."""

from __future__ import annotations

import numpy as np

from libero_data.experts.motion import Actions
from libero_data.experts.scene import Site
from libero_data.experts.skills.base import SKILLS, Context, Skill, SkillFailed
from libero_data.experts.skills.carry import best_turn, carry_to, footprint, release, wrist_options


@SKILLS.register("place_in")
class PlaceIn(Skill):
    """``place_in(obj, region)``: lower the object into the region from above and let go.

    LIBERO's ``In`` holds when the object's body lies inside the region's box. The drop
    point is the spot of the box whose column is open from above for the object's outline
    (a drawer pulled out is open only at its front), and the wrist turns the object so its
    outline fits the box. Randomised: the drop point among the open ones, release height.
    """

    name = "place_in"

    def run(self, ctx: Context) -> Actions:
        obj, region = self.args
        if ctx.held != obj:
            raise SkillFailed(f"place_in({obj}) without holding it")
        scene = ctx.scene
        site = scene.site(region)
        container = ctx.parent_of(region)
        mat = _fitting_orientation(ctx, site)
        spot = _open_spot(ctx, site, mat, container)
        if spot is None:
            raise SkillFailed(f"no open spot in {region} for {obj}")
        xy, floor = spot
        yield from carry_to(ctx, xy, floor + 0.015 + ctx.jitter(0.005), mat)
        yield from release(ctx)
        return True


def _box(site: Site) -> tuple[np.ndarray, np.ndarray]:
    """World-axis-aligned half extents of a region, as LIBERO's ``in_box`` computes them."""
    half = np.abs(site.mat @ site.size)
    return site.pos - half, site.pos + half


def _fitting_orientation(ctx: Context, site: Site) -> np.ndarray:
    """Wrist orientation whose object outline fits the region's rectangle best."""
    lo, hi = _box(site)
    room = (hi - lo)[:2] / 2
    base = ctx.scene.eef_mat()
    best, best_cost = base, np.inf
    for yaw in wrist_options(ctx):
        mat = best_turn(ctx, base, [yaw])
        outline = footprint(ctx, mat)
        extent = np.maximum(np.abs(outline.max(0)), np.abs(outline.min(0)))
        overflow = float(np.clip(extent - room, 0, None).sum())
        turn = abs(yaw)
        cost = overflow * 100 + turn * 0.01
        if cost < best_cost:
            best, best_cost = mat, cost
    return best


def _open_spot(ctx: Context, site: Site, mat: np.ndarray, container: str) -> tuple[np.ndarray, float] | None:
    """A point of the region whose column is free above the object's outline, and the floor there."""
    assert ctx.held is not None
    scene = ctx.scene
    lo, hi = _box(site)
    outline = footprint(ctx, mat)
    radius = float(np.linalg.norm(outline, axis=1).max())
    pts = scene.obstacle_points(exclude=(ctx.held,))
    local = pts[np.all((pts[:, :2] > lo[:2] - radius - 0.02) & (pts[:, :2] < hi[:2] + radius + 0.02), axis=1)]
    margin = 0.01
    xs = (
        np.linspace(lo[0] + margin, hi[0] - margin, 9)
        if hi[0] - lo[0] > 2 * margin
        else np.array([site.pos[0]])
    )
    ys = (
        np.linspace(lo[1] + margin, hi[1] - margin, 9)
        if hi[1] - lo[1] > 2 * margin
        else np.array([site.pos[1]])
    )
    candidates = []
    for x in xs:
        for y in ys:
            xy = np.array([x, y])
            dist = np.linalg.norm(local[:, :2] - xy, axis=1)
            under = dist < radius * 0.85
            # The floor is what the object's base will stand on (the middle of its outline).
            base = (dist < radius * 0.5) & (local[:, 2] < hi[2] + 0.005) & (local[:, 2] > lo[2] - 0.05)
            floor = float(local[base, 2].max()) if base.any() else float(lo[2])
            if floor > hi[2] - 0.01:
                continue
            # Something over the spot (a cabinet over its drawer, a shelf over a layer):
            # nothing can come down there.
            if (under & (local[:, 2] > hi[2] + 0.02)).any():
                continue
            # Walls and rims inside the outline: fewer is better (the object may brush one).
            rim = int((under & (local[:, 2] > floor + 0.03)).sum())
            if rim and not (dist[under & (local[:, 2] > floor + 0.03)] > radius * 0.6).all():
                continue  # a wall through the middle of the outline, not just a rim at its edge
            centre = float(np.linalg.norm(xy - site.pos[:2]))
            candidates.append((rim, centre + float(ctx.rng.uniform(0, 0.01)), xy, floor))
    if not candidates:
        return None
    candidates.sort(key=lambda c: (c[0], c[1]))
    _, _, xy, floor = candidates[0]
    return xy, floor
