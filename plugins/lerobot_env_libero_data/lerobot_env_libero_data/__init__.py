"""``lerobot-eval --env.type=libero_data``: LIBERO's tasks and libero-data's generated ones as a
LeRobot environment.

``--env.task`` takes what ``libero-data`` takes: a task (``libero_object/0``, ``suite/name``, a
``.bddl`` file), a suite (``libero_object``, every task of it), some tasks of a suite
(``libero_object/0,3``) or a suite folder made by ``libero-data generate --procedural`` or
``--variants-of``. Episodes start as ``libero-bench`` starts its rollouts: ``--env.starts=stored``
from LIBERO's stored init states (episode r from state r mod 50, the paper's protocol) or
``heldout`` from the task's held-out placements; both are the same for every policy.

Observations follow LeRobot's LIBERO environment: ``observation.images.image`` (agentview),
``observation.images.image2`` (eye-in-hand), upright, ``--env.image_size`` pixels square, and
``observation.state`` (eef position, axis-angle, gripper: 8). A policy trained on a libero-data
dataset with its default names reads the wrist camera as ``wrist_image``:
``--env.wrist_key=wrist_image``.
"""

from lerobot_env_libero_data.config import LiberoDataEnvConfig

__all__ = ["LiberoDataEnvConfig"]
