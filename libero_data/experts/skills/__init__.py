"""Reusable skills, one per file, found through the ``SKILLS`` registry."""

from libero_data.experts.skills import (  # noqa: F401
    door,
    drawer,
    knob,
    pick,
    place_in,
    place_on,
    push,
    push_aside,
    set_aside,
)
from libero_data.experts.skills.base import SKILLS, Context, Skill, SkillFailed

__all__ = ["SKILLS", "Context", "Skill", "SkillFailed"]
