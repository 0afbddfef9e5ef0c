"""Place on: set the held object down on another object or on a surface region."""

from __future__ import annotations

import numpy as np

from libero_data.experts.motion import Actions
from libero_data.experts.skills.base import SKILLS, Context, Skill, SkillFailed
from libero_data.experts.skills.carry import carry_to, footprint, release


@SKILLS.register("place_on")
class PlaceOn(Skill):
    """``place_on(obj, target)``: target is an object (its body centre) or a region site.

    LIBERO's ``On`` needs the object's body within 3 cm of the target's body (objects) or
    inside the region's rectangle (sites); the object is lowered until it is about to
    touch, then released. Randomised: a small offset of the drop point, the release height.
    """

    name = "place_on"

    def run(self, ctx: Context) -> Actions:
        obj, target = self.args
        if ctx.held != obj:
            raise SkillFailed(f"place_on({obj}) without holding it")
        scene = ctx.scene
        mat = scene.eef_mat()
        if ctx.is_entity(target):
            xy = scene.pos(target)[:2] + ctx.jitter(0.006, 2)
        else:
            sharing = sum(1 for a in ctx.problem.goal_atoms() if a.predicate == "On" and a.args[1] == target)
            xy = _free_spot(ctx, scene.site(target), mat, shared=sharing > 1)
        outline = footprint(ctx, mat)
        radius = float(np.linalg.norm(outline, axis=1).max())
        support = _support(ctx, xy, radius * 0.8, exclude=(obj,))
        yield from carry_to(ctx, xy, support + 0.012 + ctx.jitter(0.004), mat)
        yield from release(ctx)
        return True


def _free_spot(ctx: Context, site, mat: np.ndarray, *, shared: bool = False) -> np.ndarray:
    """Where in a surface region the held object's outline meets the fewest other things.

    Candidates keep the object's body at least 1 cm inside the region (LIBERO's ``On`` for
    regions checks the body position); among equally free ones the nearest the centre wins
    (with a little seeded jitter), or, when several objects go onto the region (two moka
    pots on one stove), the one farthest from the other objects, leaving room for them.
    """
    assert ctx.held is not None
    half_region = np.abs(site.mat @ site.size)[:2]
    outline = footprint(ctx, mat)
    omin, omax = outline.min(0), outline.max(0)
    mid, half = (omin + omax) / 2, np.maximum((omax - omin) / 2, 1e-3)
    pts = ctx.scene.obstacle_points(exclude=(ctx.held,))
    near = np.all(np.abs(pts[:, :2] - site.pos[:2]) < half_region + np.abs(outline).max() + 0.02, axis=1)
    pts = pts[near]
    room = np.maximum(half_region - 0.01, 0.0)
    movable = [o.name for o in ctx.problem.objects if o.name != ctx.held]
    others = np.concatenate([ctx.scene.points(o)[:, :2] for o in movable]) if movable else np.zeros((0, 2))
    best, best_key = site.pos[:2].copy(), None
    for fx in np.linspace(-1, 1, 7):
        for fy in np.linspace(-1, 1, 7):
            xy = site.pos[:2] + np.array([fx, fy]) * room
            blocked, supported = spot_cost(pts, xy + mid, half, default_floor=float(site.pos[2]))
            if supported < 0.8:
                blocked += 10_000
            if shared:
                clearance = float(np.linalg.norm(others - xy, axis=1).min()) if len(others) else 1.0
                key = (blocked, -min(clearance, 0.3) + float(ctx.rng.uniform(0, 0.005)))
            else:
                key = (blocked, float(np.linalg.norm(xy - site.pos[:2])) + float(ctx.rng.uniform(0, 0.005)))
            if best_key is None or key < best_key:
                best, best_key = xy, key
    return best


def spot_cost(
    pts: np.ndarray,
    centre: np.ndarray,
    half: np.ndarray,
    *,
    margin: float = 1.05,
    default_floor: float | None = None,
) -> tuple[int, float]:
    """How many obstacle points stand in an outline box, and how much of it rests level.

    The box is ``centre`` ± ``half`` (grown by ``margin``); the floor is the highest point
    under its middle. Returns the points more than 1 cm above that floor inside the box, and
    the share of 25 probes across the outline that have floor-level support under them (an
    object mostly off its support tips over the edge).
    """
    rel = np.abs(pts[:, :2] - centre) / half
    inside = rel.max(axis=1) < margin
    base = rel.max(axis=1) < 0.5
    if base.any():
        floor = float(pts[base, 2].max())
    elif default_floor is not None:
        floor = default_floor
    else:
        return 0, 0.0
    blocked = int((inside & (pts[:, 2] > floor + 0.01)).sum())
    level = pts[np.abs(pts[:, 2] - floor) < 0.006, :2]
    probes = centre + np.stack(np.meshgrid(*(np.linspace(-0.9, 0.9, 5),) * 2), -1).reshape(-1, 2) * half
    supported = (
        float(np.mean([bool((np.abs(level - q) < 0.006).all(axis=1).any()) for q in probes]))
        if len(level)
        else 0.0
    )
    return blocked, supported


def _support(ctx: Context, xy: np.ndarray, radius: float, exclude: tuple[str, ...]) -> float:
    pts = ctx.scene.obstacle_points(exclude=exclude)
    near = np.linalg.norm(pts[:, :2] - xy, axis=1) < radius
    return float(pts[near, 2].max()) if near.any() else ctx.table_height()
