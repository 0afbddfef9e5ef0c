"""Training presets as data: ``paper`` (LIBERO's protocol), ``quick`` (learning shown on two CPU
cores in about an hour per task; measured in benchmarks/RESULTS.md) and ``smoke`` (a 2-task run
in a few minutes that exercises everything and learns nothing). Saved as JSON beside every run
via ``to_dict``.

Values of ``paper`` come from the paper and the upstream ``libero/configs`` (train/default,
optimizer/adam_w, scheduler/cosine_annealing, eval/default, data/default).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

from libero_bench.sizes import SIZES
from libero_data.config import Config
from libero_data.registry import Registry
from libero_data.rollout import RolloutSettings
from libero_data.tasks.horizons import SUITE, StepLimit, is_step_limit

#: Model sizes every policy has (libero_bench.policies.config_base); kept here so that
#: presets load without torch.


@dataclass(frozen=True)
class TrainPreset(Config):
    """How a lifelong run trains and evaluates (the same for every task)."""

    #: What a run's preset meant by fields added after it was made (its config.json lacks them).
    legacy: ClassVar[dict[str, Any]] = {"augment": None}

    name: str
    epochs: int = 50
    batch_size: int = 32
    optimizer: str = "adamw"
    lr: float = 1e-4
    betas: tuple[float, float] = (0.9, 0.999)
    weight_decay: float = 1e-4
    scheduler: str = "cosine"  # cosine annealing from lr to lr_min over the task's epochs
    lr_min: float = 1e-5
    grad_clip: float = 100.0
    window: int = 10
    image_size: int = 128
    policy_size: str = "paper"
    algo_size: str = "paper"
    language_encoder: str = "minilm"
    eval_every: int = 5  # epochs between evaluations while learning a task
    eval_first_epoch: bool = True  # evaluate epoch 0 too (before any training)
    eval_rollouts: int = 20  # from LIBERO's stored init states (the paper's protocol)
    eval_heldout: int = 20  # from held-out sampler placements no demonstration started from
    eval_max_steps: StepLimit = (
        600  # LIBERO's; or "suite": each task's suite limit (libero_data.tasks.horizons)
    )
    eval_settle: int = 10  # no-op steps after reset before the policy acts (LIBERO waits too)
    eval_render_quality: str = "full"  # "fast": rollouts drawn from simplified meshes (libero_data.sim)
    keep_best: bool = True  # keep the checkpoint with the best success while learning a task
    demos_per_task: int | None = None  # None: all demonstrations of the task
    augment: bool | None = None  # training-time image augmentation; None: the policy size's default
    seed: int = 10000

    def rollout_settings(self) -> RolloutSettings:
        """The evaluation rounds' rollout settings (the ``eval_*`` fields), as every evaluation
        takes them (:class:`~libero_data.rollout.RolloutSettings`)."""
        return RolloutSettings(
            max_steps=self.eval_max_steps, settle=self.eval_settle, render_quality=self.eval_render_quality
        )

    def __post_init__(self) -> None:
        for field in (
            "epochs",
            "batch_size",
            "window",
            "image_size",
            "eval_every",
            "eval_rollouts",
        ):
            value = getattr(self, field)
            if isinstance(value, bool) or not isinstance(value, int) or value <= 0:
                self._fail(field, "must be a positive integer")
        if (
            isinstance(self.eval_settle, bool)
            or not isinstance(self.eval_settle, int)
            or self.eval_settle < 0
        ):
            self._fail("eval_settle", "must be a non-negative integer")
        self._check_non_negative("eval_heldout")
        if not is_step_limit(self.eval_max_steps):
            self._fail("eval_max_steps", f"must be a positive number of steps or {SUITE!r}")
        self._check_choice("eval_render_quality", ("full", "fast"))
        if not isinstance(self.eval_first_epoch, bool):
            self._fail("eval_first_epoch", "must be true or false")
        if self.augment is not None and not isinstance(self.augment, bool):
            self._fail("augment", "must be true, false or null (the policy size's default)")
        if self.demos_per_task is not None and self.demos_per_task <= 0:
            self._fail("demos_per_task", "must be positive or None")
        if not 0 < self.lr_min <= self.lr:
            self._fail("lr_min", f"must be in (0, lr = {self.lr}]")
        if self.weight_decay < 0:
            self._fail("weight_decay", "must be >= 0")
        if self.grad_clip <= 0:
            self._fail("grad_clip", "must be > 0")
        if len(self.betas) != 2 or not all(0.0 <= b < 1.0 for b in self.betas):
            self._fail("betas", "must be two numbers in [0, 1)")
        if self.optimizer != "adamw":
            self._fail("optimizer", "must be 'adamw'")
        if self.scheduler not in ("cosine", "none"):
            self._fail("scheduler", "must be 'cosine' or 'none'")
        for field in ("policy_size", "algo_size"):
            if getattr(self, field) not in SIZES:
                self._fail(field, f"must be one of {', '.join(SIZES)}")

    def with_overrides(self, assignments: list[str]) -> TrainPreset:
        """A copy with ``field=value`` assignments applied (values read as JSON, else as text)."""
        return self.with_assignments(assignments, what="preset", field="set", fixed=("name",))

    def eval_epochs(self) -> list[int]:
        """Epochs evaluated while learning a task: (0,) eval_every, 2 eval_every, ... up to ``epochs``."""
        return [e for e in range(0, self.epochs + 1, self.eval_every) if e > 0 or self.eval_first_epoch]


PAPER = TrainPreset(name="paper")

SMOKE = TrainPreset(
    name="smoke",
    epochs=2,
    batch_size=8,
    window=10,
    image_size=64,  # rendering costs the same per frame; the small images make CPU training fast
    policy_size="smoke",
    algo_size="smoke",
    eval_every=1,
    eval_rollouts=2,
    eval_heldout=1,
    eval_max_steps=40,
    demos_per_task=2,
    seed=0,
)

#: Learning shown on two CPU cores in about an hour per task (generation included): 100
#: demonstrations per task at 64x64, ResNet-T at the ``quick`` size (0.44 M parameters) on
#: 5-frame windows, batch 32, 16 epochs; one evaluation at the end (20 stored and 20 held-out
#: starts per task, each cut at its suite's step limit: libero_object 280, as LeRobot's LIBERO env
#: gives it) with ``fast`` images (simplified meshes, 4.3x cheaper rollouts on CPU).
#: A 5-frame window halves the cost of a sample, so 16 epochs cost what 8 epochs of 10-frame
#: windows did; on libero_object/1 those 8 epochs reached 15/20 and 9/20, these 16 20/20 and
#: 19/20. Measured: benchmarks/RESULTS.md, "Learning on CPU".
QUICK = TrainPreset(
    name="quick",
    epochs=16,
    batch_size=32,
    window=5,
    lr=5e-4,
    image_size=64,
    policy_size="quick",
    eval_every=16,
    eval_first_epoch=False,
    eval_rollouts=20,
    eval_heldout=20,
    eval_max_steps=SUITE,
    eval_render_quality="fast",
    seed=0,
)

PRESETS: Registry[TrainPreset] = Registry("training preset")
PRESETS.register("paper")(PAPER)
PRESETS.register("smoke")(SMOKE)
PRESETS.register("quick")(QUICK)


def get_preset(name: str) -> TrainPreset:
    """``paper``, ``quick`` or ``smoke``."""
    return PRESETS.get(name)
