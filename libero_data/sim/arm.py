"""The arm's starting pose where no stored init state gives it.

LIBERO's stored init states were recorded with robosuite's initialization noise: the seven arm
joints at the robot's initial angles plus independent Gaussian noise of 0.02 rad each,
robosuite's default, the gripper untouched (the spread per joint over every stored state of the
five suites: benchmarks/RESULTS.md, "Why the data was made again: the arm's starting pose").
LIBERO's own environment turns that noise off, so starts drawn from its placement sampler would
all begin from one arm pose, and a policy trained on them would meet the stored starts' arm
poses for the first time at evaluation. Sampler starts therefore draw the same noise, from the
reset seed.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from libero_data.errors import InputError
from libero_data.seeding import arm_noise_rng

#: Standard deviation (rad) of the noise on each arm joint, as in LIBERO's stored init states.
ARM_INIT_NOISE = 0.02
#: The largest noise accepted (rad per joint).
MAX_ARM_NOISE = 0.5


def check_arm_noise(value: float) -> None:
    """Raise :class:`InputError` unless ``value`` is a noise in [0, :data:`MAX_ARM_NOISE`] rad."""
    if not 0.0 <= value <= MAX_ARM_NOISE:
        raise InputError(f"the arm noise must be in [0, {MAX_ARM_NOISE}] rad, got {value}", field="arm_noise")


def jitter_arm(raw: Any, reset_seed: int, sd: float = ARM_INIT_NOISE) -> np.ndarray:
    """Add Gaussian noise (``sd`` rad) drawn from ``reset_seed`` to the arm's joints of the
    robosuite environment ``raw``, at rest; returns the noise applied."""
    robot = raw.robots[0]
    joints = np.asarray(robot._ref_joint_pos_indexes)
    if sd == 0:
        return np.zeros(len(joints))  # LIBERO's own reset, untouched
    noise = arm_noise_rng(reset_seed).normal(0.0, sd, len(joints))
    sim = raw.sim
    sim.data.qpos[joints] = sim.data.qpos[joints] + noise
    sim.data.qvel[robot._ref_joint_vel_indexes] = 0.0
    sim.forward()
    return noise
