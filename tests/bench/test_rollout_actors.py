"""What acts for a batch of environments, without a simulator: LeRobot's policies batched over slots
that start at different steps act as LeRobot's own select_action does for each alone; openpi's
message format round-trips and refuses what could run code; a policy server batches requests from
several connections and answers a bad one with text."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest
import torch
from bench_helpers import on_loopback
from lerobot_policies import save_policy

from libero_bench.rollouts.actors import ActionQueues, Start
from libero_bench.rollouts.lerobot_actor import LeRobotActor, raw_batch
from libero_bench.rollouts.lerobot_inputs import inputs_from_features, lerobot_config
from libero_bench.rollouts.remote import RemoteActor, connect
from libero_bench.rollouts.server import PolicyServer
from libero_bench.rollouts.wire import pack, unpack
from libero_data.errors import InputError, PolicyServerError
from libero_data.seeding import policy_noise_seed

STEPS = 9


def _observation(rng: np.random.Generator, size: int = 32) -> dict[str, np.ndarray]:
    return {
        "agentview": rng.integers(0, 256, (size, size, 3), dtype=np.uint8),
        "eye_in_hand": rng.integers(0, 256, (size, size, 3), dtype=np.uint8),
        "state": rng.normal(size=8).astype(np.float32),
    }


def _alone(folder: Path, key: str, observations: list[dict[str, np.ndarray]]) -> list[np.ndarray]:
    """LeRobot's own loop for one environment: pre-processor, select_action, post-processor."""
    from lerobot.policies.factory import get_policy_class, make_pre_post_processors

    config = lerobot_config(folder)
    policy = get_policy_class(config.type).from_pretrained(str(folder), config=config).eval()
    pre, post = make_pre_post_processors(policy_cfg=config, pretrained_path=str(folder))
    inputs = inputs_from_features(config.input_features)
    policy.reset()
    actions = []
    for t, obs in enumerate(observations):
        batch = pre(raw_batch(inputs, [obs], ["put the bowl on the plate"]))
        kwargs = {}
        if config.type == "diffusion":  # the noise the batched actor draws for this rollout and chunk
            g = torch.Generator().manual_seed(policy_noise_seed(key, t // config.n_action_steps))
            kwargs["noise"] = torch.randn((1, config.horizon, 7), generator=g)
        with torch.inference_mode():
            actions.append(post(policy.select_action(batch, **kwargs)).numpy().reshape(-1))
    return actions


@pytest.mark.parametrize("kind", ["act", "diffusion"])
def test_slots_act_as_lerobots_own_loop_for_each_environment_alone(kind: str, tmp_path: Path) -> None:
    folder = save_policy(kind, tmp_path / kind)
    rng = np.random.default_rng(0)
    episodes = {  # slot 1's first episode ends after 2 steps and its next one begins at step 2
        "a": [_observation(rng) for _ in range(STEPS)],
        "b": [_observation(rng) for _ in range(2)],
        "c": [_observation(rng) for _ in range(STEPS - 2)],
        "d": [_observation(rng) for _ in range(STEPS)],
    }
    actor = LeRobotActor(folder, "cpu")
    schedule = {0: [("a", 0)], 1: [("b", 0), ("c", 2)], 2: [("d", 0)]}
    got: dict[str, list[np.ndarray]] = {k: [] for k in episodes}
    for t in range(STEPS):
        current = {}
        for slot, plan in schedule.items():
            key, begin = max((p for p in plan if p[1] <= t), key=lambda p: p[1])
            if t == begin:
                actor.begin(slot, Start(key, "put the bowl on the plate"))
            current[slot] = (key, t - begin)
        forwards = actor.forwards
        actions = actor.act({slot: episodes[k][i] for slot, (k, i) in current.items()})
        assert actor.forwards - forwards <= 1  # one batched pass per step, whoever waits
        for slot, (k, _) in current.items():
            got[k].append(actions[slot])
    for key, observations in episodes.items():
        reference = _alone(folder, key, observations)
        np.testing.assert_allclose(np.stack(got[key]), np.stack(reference), rtol=1e-4, atol=1e-5)
    chunk = actor.queues.steps
    assert chunk is not None  # a pass wherever a slot's chunk ran out: slot 1's episodes shifted by 2
    waits = {t for t in range(STEPS) if t % chunk == 0} | {t for t in range(2, STEPS) if (t - 2) % chunk == 0}
    assert actor.forwards == len(waits)


def test_temporal_ensembling_is_refused_in_one_sentence(tmp_path: Path) -> None:
    import json

    folder = save_policy("act", tmp_path / "act")
    config = json.loads((folder / "config.json").read_text())
    config.update(temporal_ensemble_coeff=0.01, n_action_steps=1)
    (folder / "config.json").write_text(json.dumps(config))
    with pytest.raises(InputError, match="temporal_ensemble_coeff"):
        LeRobotActor(folder, "cpu")


def test_action_queues_execute_the_first_steps_of_each_chunk() -> None:
    queues = ActionQueues(steps=2)
    queues.clear(0)
    queues.clear(1)
    assert queues.waiting([1, 0]) == [0, 1]
    queues.fill(0, np.arange(21, dtype=np.float32).reshape(3, 7))
    assert queues.waiting([0, 1]) == [1]
    assert queues.pop(0)[0] == 0 and queues.pop(0)[0] == 7 and queues.waiting([0]) == [0]


def test_openpi_messages_round_trip_and_nothing_that_runs_code_passes() -> None:
    message: dict[str, Any] = {
        "observation/image": np.arange(12, dtype=np.uint8).reshape(2, 2, 3),
        "observation/state": np.linspace(0, 1, 8, dtype=np.float32),
        "prompt": "open the drawer",
        "step": np.int64(3),
        "nested": {"actions": np.ones((5, 7), dtype=np.float64)},
    }
    back = unpack(pack(message))
    assert back["prompt"] == "open the drawer" and back["step"] == 3 and isinstance(back["step"], np.int64)
    for key in ("observation/image", "observation/state"):
        np.testing.assert_array_equal(back[key], message[key])
        assert back[key].dtype == message[key].dtype
    np.testing.assert_array_equal(back["nested"]["actions"], np.ones((5, 7)))
    with pytest.raises(InputError, match="dtype object"):
        pack({"x": np.array([object()], dtype=object)})
    import msgpack

    forged = msgpack.packb({b"__ndarray__": True, b"data": b"", b"dtype": "|O", b"shape": (0,)})
    with pytest.raises(InputError, match="refused"):
        unpack(forged)


def test_a_server_batches_requests_from_several_connections_and_answers_bad_ones_in_text(
    tmp_path: Path,
) -> None:
    folder = save_policy("act", tmp_path / "act")
    served = LeRobotActor(folder, "cpu")
    server = PolicyServer(served, {"server": "libero-bench", "image_size": 32})
    rng = np.random.default_rng(1)
    observations = {
        slot: {**_observation(rng), "joint_pos": np.zeros(7), "gripper_state": np.zeros(2)} for slot in (0, 1)
    }
    with on_loopback(server) as port:
        url = f"ws://127.0.0.1:{port}"
        client = RemoteActor(url, image_size=32, replan_steps=1)
        assert client.metadata["server"] == "libero-bench"
        for slot in (0, 1):
            client.begin(slot, Start(f"k{slot}", "put the bowl on the plate"))
        remote = client.act(observations)
        # Both connections' requests went out together and were answered in one forward pass.
        assert server.batches == [2] and served.forwards == 1 and client.forwards == 1
        local = LeRobotActor(folder, "cpu")
        for slot in (0, 1):
            local.begin(slot, Start(f"k{slot}", "put the bowl on the plate"))
        np.testing.assert_allclose(
            np.stack([remote[0], remote[1]]), np.stack(list(local.act(observations).values())), atol=1e-6
        )
        client.close()
        # A request that cannot be served gets its reason as text (openpi's error reply).
        connection, _ = connect(url, timeout=30)
        connection.send(pack({"prompt": "open the drawer"}))
        reply = connection.recv(timeout=30)
        connection.close()
        assert (
            isinstance(reply, str)
            and "lacks observation/image, observation/wrist_image, observation/state" in reply
        )
    with pytest.raises(PolicyServerError, match=rf"cannot reach the policy server at {url}"):
        RemoteActor(url)
