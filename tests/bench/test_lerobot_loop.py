"""LeRobot's own policies in our simulator: trained by lerobot-train on our data, evaluated by
``libero-bench eval`` and by ``lerobot-eval`` through our environment plugin."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest

from libero_bench.rollouts.lerobot_inputs import inputs_from_features
from libero_data.errors import InputError

VENV_BIN = Path(sys.executable).parent


def _feature(kind: str, *shape: int) -> SimpleNamespace:
    return SimpleNamespace(type=SimpleNamespace(name=kind), shape=shape)


def test_inputs_are_served_under_either_camera_naming_and_an_unservable_one_is_named() -> None:
    inputs = inputs_from_features(
        {
            "observation.images.image": _feature("VISUAL", 3, 256, 256),
            "observation.images.image2": _feature("VISUAL", 3, 128, 128),
            "observation.state": _feature("STATE", 8),
            "observation.sim_state": _feature("STATE", 110),
        }
    )
    assert inputs.cameras == {
        "observation.images.image": ("agentview", 256, 256),
        "observation.images.image2": ("eye_in_hand", 128, 128),
    }
    assert inputs.states["observation.state"] == ("state", 8) and inputs.render_size == 256
    assert inputs_from_features(
        {"observation.images.wrist_image": _feature("VISUAL", 3, 64, 64)}
    ).cameras == {"observation.images.wrist_image": ("eye_in_hand", 64, 64)}
    with pytest.raises(InputError, match=r"reads observation\.environment_state of shape \[16\]"):
        inputs_from_features(
            {
                "observation.images.image": _feature("VISUAL", 3, 64, 64),
                "observation.environment_state": _feature("ENV", 16),
            }
        )
    with pytest.raises(InputError, match=r"reads the camera observation\.images\.depth"):
        inputs_from_features({"observation.images.depth": _feature("VISUAL", 3, 64, 64)})


def _run(*command: str, timeout: float = 900, cwd: Path | None = None) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, "OMP_NUM_THREADS": "1", "SVT_LOG": "1", "WANDB_MODE": "disabled"}
    return subprocess.run(command, capture_output=True, text=True, timeout=timeout, env=env, cwd=cwd)


#: A tiny ACT (a few training steps on CPU); backbone weights are not downloaded.
ACT = [
    "--policy.type=act",
    "--policy.dim_model=32",
    "--policy.dim_feedforward=64",
    "--policy.n_encoder_layers=1",
    "--policy.n_decoder_layers=1",
    "--policy.chunk_size=5",
    "--policy.n_action_steps=5",
]
DIFFUSION = [
    "--policy.type=diffusion",
    "--policy.down_dims=[16,32]",
    "--policy.crop_shape=null",
    "--policy.num_inference_steps=2",
    "--policy.horizon=8",
    "--policy.n_action_steps=4",
    "--policy.use_group_norm=false",
]


def _train(dataset: Path, out: Path, policy: list[str]) -> Path:
    result = _run(
        str(VENV_BIN / "lerobot-train"),
        *policy,
        "--policy.device=cpu",
        "--policy.pretrained_backbone_weights=null",
        "--policy.push_to_hub=false",
        "--dataset.repo_id=libero-data/libero_goal",
        f"--dataset.root={dataset}",
        "--steps=2",
        "--batch_size=2",
        "--save_freq=2",
        "--num_workers=0",
        "--wandb.enable=false",
        f"--output_dir={out}",
    )
    assert result.returncode == 0, result.stderr[-3000:]
    return out / "checkpoints" / "000002" / "pretrained_model"


@pytest.mark.sim
@pytest.mark.slow  # ~105 s (lerobot-train, then three evaluations); scripts/test runs it after the default suite
def test_a_lerobot_trained_policy_is_evaluated_with_the_benchmarks_protocol(
    tiny_dataset: Path, procedural_suite: Path, tmp_path: Path
) -> None:
    import datasets

    act = _train(tiny_dataset, tmp_path / "act", ACT)
    out = tmp_path / "eval"
    args = [
        "--tasks",
        "libero_goal/0",
        "--stored",
        "1",
        "--heldout",
        "1",
        "--max-steps",
        "5",
        "--out",
        str(out),
    ]
    result = _run(sys.executable, "-m", "libero_bench.cli", "eval", str(act), *args)
    assert result.returncode == 0, result.stderr[-3000:]
    report = json.loads((out / "report.json").read_text())
    (task,) = report["tasks"]
    for start in ("stored", "heldout"):  # every rate with n and its interval
        assert task[start]["n"] == 1 and 0.0 <= task[start]["low"] <= task[start]["high"] <= 1.0
    frames = datasets.load_dataset(str(out / "rollouts"), split="train")
    assert sorted(set(frames["episode_index"])) == [0, 1]
    assert len(list((out / "rrd").glob("*.rrd"))) == 2
    # Held-out starts skip every seed a demonstration of the task started from.
    config = json.loads((out / "config.json").read_text())
    assert config["training_data"] == str(tiny_dataset)
    demo_seeds = {
        json.loads(line)["reset_seed"]
        for line in (tiny_dataset / "meta" / "libero_episodes.jsonl").read_text().splitlines()
    }
    assert not set(config["heldout_seeds"]["open_the_middle_drawer_of_the_cabinet"]) & demo_seeds

    # The robustness sweep takes the LeRobot policy in place of a run (a function call: the
    # command line was checked with eval above).
    from libero_bench.robustness.sweep import SweepRequest, sweep

    request = SweepRequest(tasks=("libero_goal/0",), kinds=("noise",), levels=(2,), rollouts=1, max_steps=3)
    grid = sweep(act, request, tmp_path / "sweep")["table"]["grid"]
    assert grid["noise"]["0"]["n"] == 1 and grid["noise"]["2"]["n"] == 1

    # lerobot-eval finds our environment plugin: a shipped task and a generated one, with one
    # environment and with two in a batch (LeRobot batches the policy over them).
    for task_ref, batch in (("libero_goal/7", 2), (f"{procedural_suite}/0", 1)):
        le = _run(
            str(VENV_BIN / "lerobot-eval"),
            f"--policy.path={act}",
            "--policy.device=cpu",
            "--env.type=libero_data",
            f"--env.task={task_ref}",
            "--env.wrist_key=wrist_image",  # the policy learned libero-data's names
            "--env.image_size=64",
            "--env.episode_length=4",
            f"--eval.n_episodes={batch}",
            f"--eval.batch_size={batch}",
            f"--output_dir={tmp_path / 'lerobot-eval' / task_ref.replace('/', '_')}",
        )
        assert le.returncode == 0, le.stderr[-3000:]
        info = json.loads(
            (tmp_path / "lerobot-eval" / task_ref.replace("/", "_") / "eval_info.json").read_text()
        )
        assert info["overall"]["n_episodes"] == batch

    # Diffusion Policy too (its own processors, another input layout).
    diffusion = _train(tiny_dataset, tmp_path / "diffusion", DIFFUSION)
    other = tmp_path / "eval-diffusion"
    from libero_bench.evaluation.policy_eval import EvalRequest, evaluate_policy

    evaluate_policy(EvalRequest(str(diffusion), ("libero_goal/7",), 1, 0, max_steps=3), other)
    assert json.loads((other / "report.json").read_text())["all"]["stored"]["n"] == 1


@pytest.mark.sim
def test_lerobot_batches_give_every_rollout_the_start_libero_bench_gives_it(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """LeRobot's rollout over our vector environments, batch sizes 1 and 2: rollout r starts where
    libero-bench's rollout r starts, even when a sub-environment ends early and gymnasium resets it
    on its own (even rollouts here end after one step, as if they had succeeded)."""
    import torch
    from lerobot.policies.factory import get_policy_class, make_pre_post_processors
    from lerobot.scripts.lerobot_eval import rollout
    from lerobot_env_libero_data import LiberoDataEnvConfig
    from lerobot_env_libero_data.env import LiberoDataGymEnv
    from lerobot_policies import save_policy

    from libero_bench.rollouts.jobs import EvalTask
    from libero_bench.rollouts.lerobot_inputs import lerobot_config
    from libero_data.tasks import get_task

    step = LiberoDataGymEnv.step

    def succeed_early(self: LiberoDataGymEnv, action: Any) -> Any:
        obs, reward, terminated, truncated, info = step(self, action)
        return obs, reward, terminated or (self.start is not None and self.start[0] % 2 == 0), truncated, info

    monkeypatch.setattr(LiberoDataGymEnv, "step", succeed_early)
    folder = save_policy("act", tmp_path / "act")
    config = lerobot_config(folder)
    policy = get_policy_class(config.type).from_pretrained(str(folder), config=config).eval()
    pre, post = make_pre_post_processors(policy_cfg=config, pretrained_path=str(folder))
    env_config = LiberoDataEnvConfig(
        task="libero_object/0", image_size=32, episode_length=3, settle=2, wrist_key="wrist_image"
    )
    env_pre, env_post = env_config.get_env_processors()
    task = get_task("libero_object/0")
    bench = EvalTask(task.name, task.language, 0, str(task.bddl_path), np.zeros(1), task.init_states())
    expected = {r: bench.start(r)[1:] for r in range(4)}
    for n_envs in (1, 2):
        (vector,) = env_config.create_envs(n_envs)["libero_object"].values()
        seen = {}
        with torch.inference_mode():
            for _batch in range(4 // n_envs):
                rollout(vector, policy, env_pre, env_post, pre, post)
                for r, index, seed in vector.get_attr("start"):  # type: ignore[attr-defined]
                    seen[r] = (index, seed)
        vector.close()
        assert seen == expected, f"batch size {n_envs}"


@pytest.mark.sim
@pytest.mark.slow  # lerobot-train, then openpi's own loop against libero-bench serve
def test_a_policy_lerobot_trains_on_our_data_serves_openpis_own_client(
    tiny_dataset: Path, tmp_path: Path
) -> None:
    """Issue 75: every observation.* column of our datasets is one openpi's LIBERO request carries,
    so ACT trained by lerobot-train on them declares those inputs only, and openpi's loop (its
    client's requests, chunks of 5) runs two short episodes against libero-bench serve of it."""
    from bench_helpers import serving

    from benchmarks.openpi_loop import Client, run_openpi_loop
    from libero_data.tasks import get_task

    act = _train(tiny_dataset, tmp_path / "act", ACT)
    config = json.loads((act / "config.json").read_text())
    assert set(config["input_features"]) == {
        "observation.images.image",
        "observation.images.wrist_image",
        "observation.state",
    }
    steps = 6
    with serving(act) as url:
        assert Client(url).metadata["inputs"] == [
            "observation/image",
            "observation/wrist_image",
            "observation/state",
            "prompt",
        ]
        episodes = run_openpi_loop(url, get_task("libero_goal/0"), 2, steps)
    assert [len(e["actions"]) for e in episodes] == [steps, steps]
    assert all(np.all(np.isfinite(e["actions"])) for e in episodes)
