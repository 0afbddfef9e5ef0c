"""Keys of the training batch a policy receives (a dict of tensors, B = batch, T = window).

- ``AGENTVIEW`` / ``WRIST``: float32 (B, T, 3, H, W) images in [0, 1]
- ``JOINT_STATES``: float32 (B, T, 7); ``GRIPPER_STATES``: float32 (B, T, 2)
- ``TASK_EMB``: float32 (B, E) language embedding of the task
- ``ACTIONS``: float32 (B, T, 7) in [-1, 1]
- ``TASK_ID``: int64 (B,)
"""

from __future__ import annotations

AGENTVIEW = "agentview"
WRIST = "wrist"
JOINT_STATES = "joint_states"
GRIPPER_STATES = "gripper_states"
TASK_EMB = "task_emb"
ACTIONS = "actions"
TASK_ID = "task_id"

IMAGE_KEYS: tuple[str, ...] = (AGENTVIEW, WRIST)
JOINT_DIM = 7
GRIPPER_DIM = 2
ACTION_DIM = 7
