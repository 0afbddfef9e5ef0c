"""Reusable skills, one per file, found through the ``SKILLS`` registry."""

from libero_data.experts.skills import door, drawer, knob, pick, place_in, place_on, push, set_aside  # noqa: F401
from libero_data.experts.skills.base import SKILLS, Context, Skill, SkillFailed

__all__ = ["SKILLS", "Context", "Skill", "SkillFailed"]
