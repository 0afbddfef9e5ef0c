"""HDF5 files in the layout LIBERO's ``scripts/create_dataset.py`` writes, made from our own expert
episodes (nothing is downloaded): what ``libero-data import`` is tested on.

As that script does, each demonstration's first 5 steps are dropped and index k holds the state
before action k; ``init_state`` is the first kept state; ``model_file`` is the scene's MuJoCo XML
as MuJoCo writes it (fixtures where they stood); the images follow LIBERO's convention
(``macros_image_convention`` "opengl": stored upside down). Their pixels are not rendered here (an
import renders its own from the states); they are blank arrays of LIBERO's shape and type.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

DROPPED = 5


@dataclass(frozen=True)
class Episode:
    """One expert episode: where it began, its states (before each action), actions, scene XML."""

    init_index: int
    reset_seed: int
    states: np.ndarray
    actions: np.ndarray
    model_xml: str


def expert_episodes(task: Any, inits: list[int], seed: int = 0) -> list[Episode]:
    """The expert's episodes of ``task`` from these stored init states (cameras off)."""
    from libero_data.experts import Expert
    from libero_data.seeding import episode_seeds
    from libero_data.sim import EnvConfig, LiberoEnv

    stored = task.init_states()
    found = []
    with LiberoEnv(task, EnvConfig(cameras=())) as env:
        expert = Expert(env)
        for i in inits:
            reset_seed, expert_seed = episode_seeds(seed, task.id, i)
            ep = expert.run(stored[i], reset_seed=reset_seed, seed=expert_seed)
            assert ep.success, f"the expert failed {task.id} from init state {i}"
            env.reset(seed=reset_seed, render=False)  # the fixtures as the episode had them
            xml = env.sim.model.get_xml()
            found.append(Episode(i, reset_seed, np.asarray(ep.states), np.asarray(ep.actions), xml))
    return found


def write_libero_file(path: Path, task: Any, episodes: list[Episode], image_size: int = 128) -> Path:
    """A LIBERO demonstration file of ``task`` holding ``episodes``."""
    import h5py

    name = task.bddl_path.stem
    bddl_name = f"chiliocosm/bddl_files/{task.suite}/{name}.bddl"
    problem = {
        "problem_name": "libero_tabletop_manipulation",
        "domain_name": "robosuite",
        "language_instruction": task.problem.language,
    }
    path.parent.mkdir(parents=True, exist_ok=True)
    with h5py.File(path, "w") as f:
        data = f.create_group("data")
        data.attrs["env_name"] = "Libero_Tabletop_Manipulation"
        data.attrs["problem_info"] = json.dumps(problem)
        data.attrs["macros_image_convention"] = "opengl"
        data.attrs["bddl_file_name"] = bddl_name
        data.attrs["bddl_file_content"] = task.bddl_path.read_text()
        data.attrs["env_args"] = json.dumps(
            {
                "type": 1,
                "env_name": "Libero_Tabletop_Manipulation",
                "problem_name": problem["problem_name"],
                "bddl_file": bddl_name,
                "env_kwargs": {"control_freq": 20, "camera_heights": image_size, "camera_widths": image_size},
            }
        )
        total = 0
        for i, ep in enumerate(episodes):
            states, actions = ep.states[DROPPED:], ep.actions[DROPPED:]
            n = len(actions)
            group = data.create_group(f"demo_{i}")
            obs = group.create_group("obs")
            qpos = states[:, 1:10]
            obs.create_dataset("gripper_states", data=qpos[:, 7:9])
            obs.create_dataset("joint_states", data=qpos[:, :7])
            obs.create_dataset("ee_states", data=np.zeros((n, 6)))
            obs.create_dataset("ee_pos", data=np.zeros((n, 3)))
            obs.create_dataset("ee_ori", data=np.zeros((n, 3)))
            blank = np.zeros((n, image_size, image_size, 3), dtype=np.uint8)
            obs.create_dataset("agentview_rgb", data=blank, compression="gzip")
            obs.create_dataset("eye_in_hand_rgb", data=blank, compression="gzip")
            group.create_dataset("actions", data=actions)
            group.create_dataset("states", data=states)
            group.create_dataset("robot_states", data=np.zeros((n, 9)))
            rewards = np.zeros(n, dtype=np.uint8)
            rewards[-1] = 1
            group.create_dataset("rewards", data=rewards)
            group.create_dataset("dones", data=rewards.copy())
            group.attrs["num_samples"] = n
            group.attrs["model_file"] = ep.model_xml
            group.attrs["init_state"] = states[0]
            total += n
        data.attrs["num_demos"] = len(episodes)
        data.attrs["total"] = total
    return path
