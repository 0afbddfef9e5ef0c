"""Set aside: put the held object down on the table, out of a drawer's way."""

from __future__ import annotations

import numpy as np

from libero_data.experts.motion import Actions
from libero_data.experts.skills.base import SKILLS, Context, Skill, SkillFailed
from libero_data.experts.skills.carry import carry_to, footprint, release
from libero_data.experts.skills.drawer import sweep
from libero_data.experts.skills.pick import COMFORTABLE_REACH
from libero_data.experts.skills.place_on import spot_cost

#: Room left between the set-aside object and the open drawer (m): the hand must still
#: come down beside it to pick it up again.
ROOM_TO_DRAWER = 0.08


@SKILLS.register("set_aside")
class SetAside(Skill):
    """``set_aside(obj, region)``: put the held object on the table outside the drawer's sweep.

    Used before opening a drawer that would slide over the object (a bowl in front of the
    cabinet). The spot is the nearest free, level one to where the object stood that keeps
    it clear of the drawer's whole travel and within comfortable reach. Randomised: a little
    seeded jitter between equally good spots.
    """

    name = "set_aside"

    def run(self, ctx: Context) -> Actions:
        obj, region = self.args
        if ctx.held != obj:
            raise SkillFailed(f"set_aside({obj}) without holding it")
        scene = ctx.scene
        mat = scene.eef_mat()
        lo, hi = sweep(scene, region)
        outline = footprint(ctx, mat)
        omin, omax = outline.min(0), outline.max(0)
        mid, half = (omin + omax) / 2, np.maximum((omax - omin) / 2, 1e-3)
        start = scene.pos(obj)[:2].copy()
        pts = scene.obstacle_points(exclude=(obj,))
        pts = pts[np.linalg.norm(pts[:, :2] - start, axis=1) < 0.45]
        table = ctx.table_height()
        shoulder = scene.shoulder_pos()
        best, best_key = None, None
        for r in np.arange(0.04, 0.36, 0.02):
            for a in np.linspace(0.0, 2 * np.pi, 24, endpoint=False):
                xy = start + r * np.array([np.cos(a), np.sin(a)])
                box_lo, box_hi = xy + omin, xy + omax
                if np.all(box_lo < hi[:2] + ROOM_TO_DRAWER) and np.all(box_hi > lo[:2] - ROOM_TO_DRAWER):
                    continue
                reach = float(np.linalg.norm(np.array([*xy, table + 0.05]) - shoulder))
                if reach > COMFORTABLE_REACH - 0.05:
                    continue
                blocked, supported = spot_cost(pts, xy + mid, half, margin=1.4)
                if blocked or supported < 0.8:
                    continue
                key = r + float(ctx.rng.uniform(0.0, 0.01))
                if best_key is None or key < best_key:
                    best, best_key = xy, key
        if best is None:
            raise SkillFailed(f"no free spot on the table to set {obj} aside")
        yield from carry_to(ctx, best, table + 0.012 + ctx.jitter(0.003), mat)
        yield from release(ctx)
        return True
