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

Then the policy's own pre-processor (normalisation, tokenisation, device), its action chunks and
post-processor run as ``lerobot-eval`` runs them, batched over environments
(:mod:`libero_bench.rollouts.lerobot_actor`). An input nothing here can serve is named in one
sentence before any rollout starts.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from libero_data.errors import InputError, MissingFileError, PolicyFolderError, first_line
from libero_data.runtime.files import read_json

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


def inputs_from_features(input_features: Mapping[str, Any], policy: str = "the policy") -> Inputs:
    """How to make every declared input (``{name: PolicyFeature}``); :class:`InputError` naming
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


def lerobot_config(path: Path) -> Any:
    """The policy's LeRobot config (``config.json`` of a ``pretrained_model/`` folder)."""
    import lerobot.policies  # noqa: F401  (registers LeRobot's policy types)
    from lerobot.configs.policies import PreTrainedConfig
    from lerobot.utils.import_utils import register_third_party_plugins

    register_third_party_plugins()  # policies of installed lerobot_policy_* packages too
    from libero_bench.runs.folder import RunFolder

    path = Path(path)
    if RunFolder(path).is_run():
        raise InputError(
            f"{path} is a libero-bench run folder, not a LeRobot policy folder; give it to libero-bench eval, "
            "robustness or serve as a run",
            field="policy",
        )
    if not (path / "config.json").is_file():
        raise MissingFileError(
            f"{path} is not a LeRobot policy folder (no config.json); give the pretrained_model/ folder "
            "lerobot-train writes"
        )
    read_json(path / "config.json")  # not JSON at all: one sentence naming the line
    try:
        config = PreTrainedConfig.from_pretrained(str(path))
    except Exception as exc:  # draccus, JSON and type errors alike: the file is not a policy config
        raise PolicyFolderError(
            f"{path / 'config.json'} is not a LeRobot policy config ({first_line(exc)})"
        ) from None
    _check_weights(path / "model.safetensors")
    return config


def _check_weights(path: Path) -> None:
    """The policy's weights exist and are a safetensors file (read without unpickling anything)."""
    from safetensors import SafetensorError, safe_open

    from libero_bench.runs.state_files import is_pickle

    if not path.is_file():
        raise MissingFileError(f"the policy's weights {path} are missing")
    if is_pickle(path):
        raise PolicyFolderError(f"{path} is a pickle, not safetensors; pickles are not opened here")
    try:
        with safe_open(str(path), framework="pt") as f:
            names = list(f.keys())
    except (SafetensorError, OSError, ValueError) as exc:
        raise PolicyFolderError(f"{path} is not a safetensors file ({first_line(exc)})") from None
    if not names:
        raise PolicyFolderError(f"{path} holds no weights")
