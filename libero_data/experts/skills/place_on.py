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
            site = scene.site(target)
            room = np.maximum(site.size[:2] - 0.02, 0.0)
            xy = site.pos[:2] + ctx.rng.uniform(-1, 1, 2) * np.minimum(room, 0.01)
        outline = footprint(ctx, mat)
        radius = float(np.linalg.norm(outline, axis=1).max())
        support = _support(ctx, xy, radius * 0.8, exclude=(obj,))
        yield from carry_to(ctx, xy, support + 0.012 + ctx.jitter(0.004), mat)
        yield from release(ctx)
        return True


def _support(ctx: Context, xy: np.ndarray, radius: float, exclude: tuple[str, ...]) -> float:
    pts = ctx.scene.obstacle_points(exclude=exclude)
    near = np.linalg.norm(pts[:, :2] - xy, axis=1) < radius
    return float(pts[near, 2].max()) if near.any() else ctx.table_height()
