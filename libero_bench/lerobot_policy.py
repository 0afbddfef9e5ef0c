"""LeRobot's own policies (ACT, Diffusion Policy, SmolVLA, pi0 ...) acting in our simulator.

A policy is the ``pretrained_model/`` folder ``lerobot-train`` writes (its ``config.json``,
weights and processor pipelines). The observation it gets is built from its declared input
features, whatever names its training data used:

- a camera input (``observation.images.<name>``) is served by the agentview camera for names
  such as ``image``, ``agentview``, ``front``, and by the eye-in-hand camera for ``image2``,
  ``wrist_image``, ``wrist``, ``eye_in_hand``; images are upright, float in [0, 1], resized to
  the input's shape;
- ``observation.state`` is LeRobot's 8-D LIBERO state (eef position, axis-angle, gripper), and
  the other states libero-data datasets store (joint positions, gripper state, eef pose, the
  MuJoCo state) are served under their names;
- the task's instruction is the batch's ``task``.

Then the policy's own pre-processor (normalisation, tokenisation, device), ``select_action``
and post-processor run as ``lerobot-eval`` runs them. An input nothing here can serve is named
in one sentence before any rollout starts.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from libero_data.errors import InputError, MissingFileError

if TYPE_CHECKING:
    from libero_bench.evaluate import RolloutJob, RolloutResult
    from libero_data.runtime.jobs import WorkerContext

#: Camera input names -> our cameras.
CAMERA_NAMES = {
    "agentview": ("image", "agentview", "agentview_image", "front", "image1", "top", "main"),
    "eye_in_hand": ("image2", "wrist_image", "wrist", "eye_in_hand", "robot0_eye_in_hand_image", "hand"),
}
#: State inputs -> (the environment observation that serves them, their width).
STATE_INPUTS = {
    "observation.state": ("state", 8),
    "observation.joint_positions": ("joint_pos", 7),
    "observation.gripper_state": ("gripper_state", 2),
    "observation.eef_pose": ("eef_pose", 7),
}
SIM_STATE, SIM_STATE_DIM = "observation.sim_state", "observation.sim_state_dim"


@dataclass(frozen=True)
class Inputs:
    """How each input of a policy is made from an environment observation."""

    cameras: dict[str, tuple[str, int, int]]  # input -> (our camera, height, width)
    states: dict[str, tuple[str, int]]  # input -> (our observation key or the MuJoCo state, width)

    @property
    def render_size(self) -> int:
        """The camera size to render at (the largest any input reads)."""
        return max((max(h, w) for _, h, w in self.cameras.values()), default=128)


def serve(input_features: Mapping[str, Any], policy: str = "the policy") -> Inputs:
    """How to serve every declared input (``{name: PolicyFeature}``); :class:`InputError` naming
    the first one that cannot be served."""
    cameras: dict[str, tuple[str, int, int]] = {}
    states: dict[str, tuple[str, int]] = {}
    for name, feature in input_features.items():
        kind = getattr(feature.type, "name", str(feature.type))
        shape = tuple(int(v) for v in feature.shape)
        if kind == "VISUAL":
            camera = next((c for c, names in CAMERA_NAMES.items() if name.rsplit(".", 1)[-1] in names), None)
            if camera is None or len(shape) != 3:
                raise InputError(
                    f"{policy} reads the camera {name}, which none of agentview ({', '.join(CAMERA_NAMES['agentview'])}) "
                    f"or eye-in-hand ({', '.join(CAMERA_NAMES['eye_in_hand'])}) can serve",
                    field="policy",
                )
            cameras[name] = (camera, shape[1], shape[2])
        elif name in STATE_INPUTS and shape == (STATE_INPUTS[name][1],):
            states[name] = STATE_INPUTS[name]
        elif name in (SIM_STATE, SIM_STATE_DIM) and len(shape) == 1:
            states[name] = (name, shape[0])
        else:
            raise InputError(
                f"{policy} reads {name} of shape {list(shape)}, which libero-bench cannot serve "
                "(it serves cameras, observation.state (8), joint positions (7), gripper state (2), eef pose (7) "
                "and the MuJoCo state)",
                field="policy",
            )
    if not cameras:
        raise InputError(
            f"{policy} reads no camera; libero-bench serves policies that see the scene", field="policy"
        )
    return Inputs(cameras, states)


def policy_config(path: Path) -> Any:
    """The policy's LeRobot config (``config.json`` of a ``pretrained_model/`` folder)."""
    import lerobot.policies  # noqa: F401  (registers LeRobot's policy types)
    from lerobot.configs.policies import PreTrainedConfig
    from lerobot.utils.import_utils import register_third_party_plugins

    register_third_party_plugins()  # policies of installed lerobot_policy_* packages too
    path = Path(path)
    if not (path / "config.json").is_file():
        raise MissingFileError(
            f"{path} is not a LeRobot policy folder (no config.json); give the pretrained_model/ folder "
            "lerobot-train writes"
        )
    return PreTrainedConfig.from_pretrained(str(path))


@dataclass
class LeRobotActor:
    """A loaded LeRobot policy with its processors, acting on environment observations."""

    policy: Any
    preprocessor: Any
    postprocessor: Any
    inputs: Inputs

    @classmethod
    def load(cls, path: Path) -> LeRobotActor:
        import torch
        from lerobot.policies.factory import get_policy_class, make_pre_post_processors

        torch.set_num_threads(1)
        config = policy_config(path)
        config.device = "cpu"
        policy = get_policy_class(config.type).from_pretrained(str(path), config=config)
        policy.eval()
        pre, post = make_pre_post_processors(
            policy_cfg=config,
            pretrained_path=str(path),
            preprocessor_overrides={"device_processor": {"device": "cpu"}},
        )
        return cls(policy, pre, post, serve(config.input_features, f"the {config.type} policy at {path}"))

    def reset(self) -> None:
        self.policy.reset()

    def batch(self, obs: Mapping[str, Any], instruction: str) -> dict[str, Any]:
        """The one-frame batch LeRobot's ``rollout`` would build from this observation."""
        import torch
        import torch.nn.functional as F

        batch: dict[str, Any] = {"task": [instruction]}
        for name, (camera, h, w) in self.inputs.cameras.items():
            image = torch.from_numpy(np.ascontiguousarray(obs[camera])).permute(2, 0, 1)[None].float() / 255.0
            if image.shape[-2:] != (h, w):
                image = F.interpolate(
                    image, size=(h, w), mode="bilinear", antialias=True, align_corners=False
                )
            batch[name] = image
        for name, (key, width) in self.inputs.states.items():
            batch[name] = torch.from_numpy(self._state(obs, key, width))[None]
        return batch

    @staticmethod
    def _state(obs: Mapping[str, Any], key: str, width: int) -> np.ndarray:
        if key == "eef_pose":
            return np.concatenate([obs["eef_pos"], obs["eef_quat"]]).astype(np.float32)
        if key == SIM_STATE:
            padded = np.zeros(width, dtype=np.float32)
            state = np.asarray(obs["sim_state"], dtype=np.float32)[:width]
            padded[: state.shape[0]] = state
            return padded
        if key == SIM_STATE_DIM:
            return np.array([len(obs["sim_state"])], dtype=np.float32)
        return np.asarray(obs[key], dtype=np.float32)

    def act(self, obs: Mapping[str, Any], instruction: str) -> np.ndarray:
        import torch

        with torch.inference_mode():
            action = self.policy.select_action(self.preprocessor(self.batch(obs, instruction)))
            action = self.postprocessor(action)
        return np.asarray(action.detach().cpu().numpy()).reshape(-1)[:7]


def run_lerobot_rollout(ctx: WorkerContext, job: RolloutJob) -> RolloutResult:
    """Roll a LeRobot policy (the folder ``ctx.shared``) out once and store the rollout."""
    from libero_bench.evaluate import roll_out_and_store

    assert ctx.shared is not None, "a LeRobot rollout needs the policy folder"
    folder = ctx.shared
    actor = ctx.cache.get("policy", str(folder), lambda: LeRobotActor.load(folder))
    actor.reset()
    return roll_out_and_store(ctx, job, lambda obs: actor.act(obs, job.language))
