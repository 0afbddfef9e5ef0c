"""Writing episodes: LeRobot v3 datasets (through lerobot itself) and MCAP logs."""

from libero_data.record.features import (
    ACTION,
    OBS_EEF_POSE,
    OBS_GRIPPER,
    OBS_IMAGE,
    OBS_JOINTS,
    OBS_SIM_STATE,
    OBS_SIM_STATE_DIM,
    OBS_STATE,
    OBS_WRIST_IMAGE,
    dataset_features,
    frame_from_observation,
)

__all__ = [
    "ACTION",
    "OBS_EEF_POSE",
    "OBS_GRIPPER",
    "OBS_IMAGE",
    "OBS_JOINTS",
    "OBS_SIM_STATE",
    "OBS_SIM_STATE_DIM",
    "OBS_STATE",
    "OBS_WRIST_IMAGE",
    "dataset_features",
    "frame_from_observation",
]
