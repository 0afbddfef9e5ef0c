"""How an evaluation rollout runs, the same wherever it runs: a run's evaluation rounds
(``TrainPreset.rollout_settings``), ``libero-bench eval`` and ``robustness`` (their requests are
these settings plus what to evaluate) and the LeRobot plugin (``--env.episode_length``,
``--env.settle``, ``--env.render_quality``)."""

from __future__ import annotations

from dataclasses import dataclass, field

from libero_data.config import Config
from libero_data.errors import InputError
from libero_data.tasks.horizons import SUITE, StepLimit, check_step_limit, step_limit


@dataclass(frozen=True)
class RolloutSettings(Config):
    """The step limit (a number, or each task's suite limit: :mod:`libero_data.tasks.horizons`),
    the no-op steps after a reset before the policy acts (LIBERO and LeRobot wait 10), and the
    images' render quality (``full``: LIBERO's renderer, ``fast``: simplified meshes)."""

    max_steps: StepLimit = field(default=SUITE, kw_only=True)
    settle: int = field(default=10, kw_only=True)
    render_quality: str = field(default="full", kw_only=True)

    def __post_init__(self) -> None:
        from libero_data.sim.env import check_render_quality

        check_step_limit(self.max_steps)
        if isinstance(self.settle, bool) or not isinstance(self.settle, int) or self.settle < 0:
            raise InputError(f"settle steps must be 0 or more, got {self.settle!r}", field="settle")
        check_render_quality(self.render_quality)

    def steps_for(self, suite: str) -> int:
        """The step limit of a task of ``suite``."""
        return step_limit(self.max_steps, suite)

    def rollout_settings(self) -> RolloutSettings:
        """These settings alone (a request built on them carries more)."""
        return RolloutSettings(
            max_steps=self.max_steps, settle=self.settle, render_quality=self.render_quality
        )
