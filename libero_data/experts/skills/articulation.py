"""Shared facts about articulated parts: which joint, which way is open, where to hold."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from libero_data.bddl import Atom
from libero_data.experts.scene import Joint, SceneView
from libero_data.experts.skills.base import Context, SkillFailed


@dataclass(frozen=True)
class Part:
    """A drawer or door: its joint, the fixture it belongs to, and the opening direction."""

    region: str  # the BDDL name in the goal (a region site or the fixture itself)
    fixture: str
    joint: Joint
    open_sign: float  # +1 when opening increases the joint position

    def opened_by(self, ctx: Context) -> float:
        """How far the part is open now, in joint units (positive = more open)."""
        return self.opened_in(ctx.scene)

    def opened_in(self, scene: SceneView) -> float:
        return self.open_sign * (scene.joint(self.joint.name).qpos - self.closed_qpos)

    @property
    def closed_qpos(self) -> float:
        lo, hi = self.joint.range
        return lo if self.open_sign > 0 else hi


def part_of(ctx: Context, name: str) -> Part:
    """The articulated part a goal atom names (``wooden_cabinet_1_top_region``, ``microwave_1``)."""
    return part_in(ctx.scene, name)


def part_in(scene: SceneView, name: str) -> Part:
    """:func:`part_of` for a scene (when planning, before any skill runs)."""
    raw = scene.raw
    if name in raw.object_sites_dict and getattr(raw.object_sites_dict[name], "joints", None):
        joint_names = list(raw.object_sites_dict[name].joints)
        fixture = raw.object_sites_dict[name].parent_name
    else:
        fixture = name
        joint_names = [j.name for j in scene.joints_of(name)]
    if not joint_names:
        raise SkillFailed(f"{name} has no joint to open or close")
    joint = scene.joint(joint_names[0])
    props = raw.get_object(fixture).object_properties.get("articulation", {})
    open_range = props.get("default_open_ranges") or []
    lo, hi = joint.range
    if open_range:
        open_sign = 1.0 if np.mean(open_range) > (lo + hi) / 2 else -1.0
    else:
        open_sign = 1.0 if abs(hi) > abs(lo) else -1.0
    return Part(region=name, fixture=fixture, joint=joint, open_sign=open_sign)


def holds(ctx: Context, predicate: str, name: str) -> bool:
    return bool(ctx.scene.env.holds(Atom(predicate, (name,))))
