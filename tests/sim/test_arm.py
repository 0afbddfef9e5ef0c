"""Sampler starts hold the arm as LIBERO's stored init states do: initial joint angles plus
Gaussian noise of 0.02 rad per joint, drawn from the reset seed."""

from __future__ import annotations

import numpy as np
import pytest

from libero_data.sim import EnvConfig, LiberoEnv
from libero_data.sim.arm import ARM_INIT_NOISE
from libero_data.tasks import get_task

pytestmark = pytest.mark.sim

TASK = "libero_object/1"
ARM = slice(1, 8)  # the flat state is (time, qpos, qvel); the arm's joints come first


def _arm_starts(env: LiberoEnv, seeds: range) -> np.ndarray:
    return np.array([env.reset(seed=s, render=False)["joint_pos"] for s in seeds])


def test_sampler_starts_spread_the_arm_like_the_stored_init_states() -> None:
    task = get_task(TASK)
    stored = task.init_states()[:, ARM]
    with LiberoEnv(task, EnvConfig(cameras=())) as env:
        starts = _arm_starts(env, range(60))
    with LiberoEnv(task, EnvConfig(cameras=(), arm_noise=0.0)) as quiet:
        still = _arm_starts(quiet, range(3))
    # Without noise every reset holds the arm at one pose, the centre of the stored states.
    assert np.ptp(still, axis=0).max() == 0.0
    assert np.abs(stored.mean(axis=0) - still[0]).max() < 0.01
    for sample in (stored, starts):
        spread = (sample - still[0]).std(axis=0)
        assert np.all((spread > 0.6 * ARM_INIT_NOISE) & (spread < 1.5 * ARM_INIT_NOISE)), spread
    assert np.abs(starts.mean(axis=0) - still[0]).max() < 0.015


def test_arm_noise_follows_the_seed_and_leaves_stored_starts_alone() -> None:
    task = get_task(TASK)
    state = task.init_states()[4]
    with LiberoEnv(task, EnvConfig(cameras=())) as env:
        a = env.reset(seed=11, render=False)["sim_state"]
        env.reset(seed=12, render=False)
        b = env.reset(seed=11, render=False)["sim_state"]
        from_stored = env.reset(state, seed=11, render=False)["sim_state"]
    np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(from_stored[ARM], state[ARM])


def test_generate_builds_its_environments_with_the_requested_arm_noise() -> None:
    from libero_data.pipeline.episodes import expert_env
    from libero_data.pipeline.request import GenerateRequest
    from libero_data.runtime.jobs import WorkerCache

    task = get_task(TASK)
    cache = WorkerCache()
    for noise in (0.0, 0.02):
        request = GenerateRequest("libero_object", (1,), image_size=64, arm_noise=noise)
        env, _expert = expert_env(
            cache, task, request.image_size, (), request.render_quality, request.arm_noise
        )
        assert env.config.arm_noise == noise
    env.close()
