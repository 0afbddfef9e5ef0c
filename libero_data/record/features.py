"""Feature keys and shapes of libero-data datasets (LeRobot's LIBERO naming).

``observation.images.image`` is LIBERO's agentview camera and the eye-in-hand camera is
``observation.images.wrist_image`` (the ``libero-data`` profile, as LeRobot's LIBERO datasets on
the Hub name it) or ``observation.images.image2`` (the ``lerobot-libero`` profile, as LeRobot's
LIBERO environment names it); both are stored upright.
``observation.state`` is the 8-D state policies usually read (eef position, eef axis-angle,
gripper finger positions), ``action`` the 7-D OSC delta pose + gripper command.

Those are every ``observation.*`` column: what a LIBERO policy reads (openpi's request carries the
two cameras and the state). LeRobot makes every ``observation.*`` column of a dataset an input of
the policy it trains (``dataset_to_policy_features``) and passes the others by, so the rest is
stored under ``libero.*``: the arm's joints and the gripper's fingers (libero-bench's policies read
them, as the LIBERO paper's do), the end-effector pose, and the flattened MuJoCo state of every
frame, padded to the dataset's widest task with its true width beside it, so any frame can be
restored exactly. The MuJoCo state is float64 stored bit for bit as int64 (``LeRobotDataset``
turns a float64 column into float32, an int64 one into int64): :func:`sim_states` reads it back,
exactly, from whatever reader returned it. Datasets made before (``observation.joint_positions``,
``observation.gripper_state``, ``observation.eef_pose``, ``observation.sim_state`` as float64,
``observation.sim_state_dim``) are still read (:class:`StoredColumns`).
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from libero_data.config import Config
from libero_data.errors import InputError

OBS_IMAGE = "observation.images.image"
OBS_WRIST_IMAGE = "observation.images.wrist_image"
OBS_STATE = "observation.state"
ACTION = "action"
JOINTS = "libero.joint_positions"
GRIPPER = "libero.gripper_state"
EEF_POSE = "libero.eef_pose"
SIM_STATE = "libero.sim_state"
SIM_STATE_DIM = "libero.sim_state_dim"

OBS_IMAGE2 = "observation.images.image2"

#: Naming profiles: our camera names -> dataset keys.
PROFILES: dict[str, dict[str, str]] = {
    "libero-data": {"agentview": OBS_IMAGE, "eye_in_hand": OBS_WRIST_IMAGE},
    "lerobot-libero": {"agentview": OBS_IMAGE, "eye_in_hand": OBS_IMAGE2},
}
#: The image size a profile gets where none is asked for (LeRobot's LIBERO datasets are 256x256).
PROFILE_IMAGE_SIZE = {"libero-data": 128, "lerobot-libero": 256}
CAMERAS = ("agentview", "eye_in_hand")
#: our camera names -> dataset keys of the default profile
CAMERA_KEYS = PROFILES["libero-data"]


@dataclass(frozen=True)
class FeatureLayout:
    """What a dataset stores of each frame's images: the naming profile, the cameras, the size."""

    profile: str = "libero-data"
    cameras: tuple[str, ...] = CAMERAS
    image_size: int = 128

    def __post_init__(self) -> None:
        if self.profile not in PROFILES:
            raise InputError(
                f"unknown feature naming {self.profile!r}; choose {' or '.join(PROFILES)}", field="features"
            )
        bad = [c for c in self.cameras if c not in CAMERAS]
        if bad or not self.cameras or len(set(self.cameras)) != len(self.cameras):
            raise InputError(
                f"cameras must be one or both of {', '.join(CAMERAS)}, got {', '.join(self.cameras)}",
                field="cameras",
            )

    @property
    def camera_keys(self) -> dict[str, str]:
        """Our camera names -> the dataset's keys, for the stored cameras."""
        return {c: PROFILES[self.profile][c] for c in self.cameras}


def camera_keys_of(features: dict[str, Any]) -> dict[str, str]:
    """The cameras a dataset stores (its ``info.json`` features) -> their keys, whatever profile."""
    found = {}
    for camera in CAMERAS:
        for profile in PROFILES.values():
            if profile[camera] in features:
                found[camera] = profile[camera]
                break
    return found


@dataclass(frozen=True)
class StoredColumns(Config):
    """Where a dataset keeps what a frame holds beyond a policy's inputs (see the module
    docstring): under ``libero.*`` in a dataset made now; a dataset made before kept them under
    ``observation.*``, the MuJoCo state as float64 (:attr:`legacy`)."""

    joints: str = JOINTS
    gripper: str = GRIPPER
    eef_pose: str = EEF_POSE
    sim_state: str = SIM_STATE
    sim_state_dim: str = SIM_STATE_DIM

    legacy: ClassVar[dict[str, Any]] = {
        "joints": "observation.joint_positions",
        "gripper": "observation.gripper_state",
        "eef_pose": "observation.eef_pose",
        "sim_state": "observation.sim_state",
        "sim_state_dim": "observation.sim_state_dim",
    }

    @classmethod
    def of(cls, features: Iterable[str]) -> StoredColumns:
        """The columns of a dataset with these features (``info.json``'s, or its column names)."""
        names = set(features)
        return cls() if SIM_STATE in names or JOINTS in names else cls(**cls.legacy)


def sim_states(values: Any, key: str = SIM_STATE) -> np.ndarray:
    """MuJoCo states (frames x width, float64) exactly as stored, from the column ``key`` as any
    reader returns it (Parquet, ``datasets``, ``LeRobotDataset``'s tensors): int64 bit patterns
    (``libero.sim_state``), or float64 (a dataset made before: :class:`StoredColumns`)."""
    if hasattr(values, "numpy"):  # a torch tensor
        values = values.numpy()
    if key == SIM_STATE:
        return np.ascontiguousarray(np.asarray(values, dtype=np.int64)).view(np.float64)
    return np.asarray(values, dtype=np.float64)


STATE_NAMES = ["eef_x", "eef_y", "eef_z", "eef_ax", "eef_ay", "eef_az", "gripper_left", "gripper_right"]
ACTION_NAMES = ["dx", "dy", "dz", "drx", "dry", "drz", "gripper"]
JOINT_NAMES = [f"joint_{i}" for i in range(1, 8)]
EEF_POSE_NAMES = ["x", "y", "z", "qx", "qy", "qz", "qw"]


def dataset_features(
    layout: FeatureLayout, sim_state_width: int, *, use_videos: bool = True
) -> dict[str, dict[str, Any]]:
    """The LeRobot feature spec of a dataset with the layout's cameras, names and image size."""
    image = {
        "dtype": "video" if use_videos else "image",
        "shape": (layout.image_size, layout.image_size, 3),
        "names": ["height", "width", "channel"],
    }
    return {
        **{key: dict(image) for key in layout.camera_keys.values()},
        OBS_STATE: {"dtype": "float32", "shape": (8,), "names": STATE_NAMES},
        ACTION: {"dtype": "float32", "shape": (7,), "names": ACTION_NAMES},
        JOINTS: {"dtype": "float32", "shape": (7,), "names": JOINT_NAMES},
        GRIPPER: {"dtype": "float32", "shape": (2,), "names": ["left", "right"]},
        EEF_POSE: {"dtype": "float32", "shape": (7,), "names": EEF_POSE_NAMES},
        SIM_STATE: {"dtype": "int64", "shape": (sim_state_width,), "names": None},
        SIM_STATE_DIM: {"dtype": "int64", "shape": (1,), "names": None},
    }


def frame_from_observation(
    obs: dict[str, Any], action: np.ndarray, sim_state_width: int, layout: FeatureLayout | None = None
) -> dict[str, Any]:
    """One LeRobot frame (without ``task``) from a :class:`~libero_data.sim.LiberoEnv` observation."""
    state = np.asarray(obs["sim_state"], dtype=np.float64)
    if state.shape[0] > sim_state_width:
        raise ValueError(
            f"MuJoCo state has {state.shape[0]} values, more than the dataset's {sim_state_width}"
        )
    padded = np.zeros(sim_state_width, dtype=np.float64)
    padded[: state.shape[0]] = state
    frame: dict[str, Any] = {
        OBS_STATE: np.asarray(obs["state"], dtype=np.float32),
        ACTION: np.asarray(action, dtype=np.float32),
        JOINTS: np.asarray(obs["joint_pos"], dtype=np.float32),
        GRIPPER: np.asarray(obs["gripper_state"], dtype=np.float32),
        EEF_POSE: np.concatenate([obs["eef_pos"], obs["eef_quat"]]).astype(np.float32),
        SIM_STATE: padded.view(np.int64),  # bit for bit (sim_states reads it back)
        SIM_STATE_DIM: np.array([state.shape[0]], dtype=np.int64),
    }
    for camera, key in (layout or FeatureLayout()).camera_keys.items():
        if camera in obs:
            frame[key] = obs[camera]
    return frame
