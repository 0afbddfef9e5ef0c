"""Writing episodes: LeRobot v3 datasets (through lerobot itself) and MCAP logs."""

from libero_data.record.features import (
    ACTION,
    EEF_POSE,
    GRIPPER,
    JOINTS,
    OBS_IMAGE,
    OBS_STATE,
    OBS_WRIST_IMAGE,
    SIM_STATE,
    SIM_STATE_DIM,
    StoredColumns,
    dataset_features,
    frame_from_observation,
    sim_states,
)

__all__ = [
    "ACTION",
    "EEF_POSE",
    "GRIPPER",
    "JOINTS",
    "OBS_IMAGE",
    "OBS_STATE",
    "OBS_WRIST_IMAGE",
    "SIM_STATE",
    "SIM_STATE_DIM",
    "StoredColumns",
    "dataset_features",
    "frame_from_observation",
    "sim_states",
]
