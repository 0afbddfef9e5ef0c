"""Same bits on any x86-64 machine: the controller off BLAS, the pinned numeric path, the fingerprint.

Other machines are simulated on this one: ``OPENBLAS_CORETYPE`` makes OpenBLAS run another
kernel (as a CPU of another generation would pick) and ``NPY_DISABLE_CPU_FEATURES`` takes
NumPy's AVX-512 code away (as on a CPU without it). Both only act when a process starts, so
each "machine" is a subprocess.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from libero_data.numerics import NUMPY_AVX512, OPT_OUT, PINNED_KERNEL, differences, machine_fingerprint
from libero_data.sim import EnvConfig, LiberoEnv
from libero_data.tasks import get_task

pytestmark = pytest.mark.sim

ROOT = Path(__file__).resolve().parents[2]
# Kernels every x86-64 CPU that runs MuJoCo (AVX) can run; OpenBLAS does not check a forced one.
OTHER_KERNELS = ("Nehalem", "Sandybridge")


def _probe(what: str, **env: str) -> dict:
    # Each probe plays one machine: nothing of this process's numeric path leaks into it (the
    # suite itself may run with LIBERO_DATA_NUMERICS=native, under another kernel).
    run_env = {
        k: v
        for k, v in os.environ.items()
        if k not in ("OPENBLAS_CORETYPE", "NPY_DISABLE_CPU_FEATURES", OPT_OUT)
    }
    run_env.update(env)
    done = subprocess.run(
        [sys.executable, "-m", "tests.numeric_probe", what],
        cwd=ROOT,
        env=run_env,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert done.returncode == 0, done.stderr[-3000:]
    return json.loads(done.stdout.strip().splitlines()[-1])


def _kernels(result: dict) -> set[str]:
    return {b["kernel"] for b in result["fingerprint"]["blas"]}


def test_replays_and_expert_episodes_are_the_same_under_other_blas_kernels() -> None:
    # Nothing pinned: each process keeps the kernel and NumPy dispatch it was given. Before the
    # controller came off BLAS, the torques of the very first substep already differed.
    a = _probe("episode", **{OPT_OUT: "native", "OPENBLAS_CORETYPE": OTHER_KERNELS[0]})
    b = _probe(
        "episode",
        **{
            OPT_OUT: "native",
            "OPENBLAS_CORETYPE": OTHER_KERNELS[1],
            "NPY_DISABLE_CPU_FEATURES": " ".join(NUMPY_AVX512),
        },
    )
    assert _kernels(a) == {OTHER_KERNELS[0]} and _kernels(b) == {OTHER_KERNELS[1]}
    assert a["fingerprint"]["numeric_key"] != b["fingerprint"]["numeric_key"]
    assert a["replay"] == b["replay"], "a replay of the same actions depends on the BLAS kernel"
    assert a["expert"] == b["expert"], "the expert's episode depends on the BLAS kernel"
    assert a["expert"][1] > 50, "the episode is a real one (its outcome is not the point here)"


def test_the_pin_overrides_the_kernel_a_machine_would_pick() -> None:
    given = _probe("fingerprint", OPENBLAS_CORETYPE=OTHER_KERNELS[0])
    native = _probe("fingerprint", **{OPT_OUT: "native", "OPENBLAS_CORETYPE": OTHER_KERNELS[0]})
    assert given["pin"] == "pinned" and given["fingerprint"]["numerics"] == "pinned"
    assert _kernels(given) == {PINNED_KERNEL}
    assert not any(s.startswith("AVX512") for s in given["fingerprint"]["numpy_simd"])
    assert native["pin"].startswith("native") and native["fingerprint"]["numerics"] == "native"
    assert _kernels(native) == {OTHER_KERNELS[0]}
    said = differences(native["fingerprint"], given["fingerprint"])
    assert any(OTHER_KERNELS[0] in line and PINNED_KERNEL in line for line in said), said
    # This test process was pinned by conftest before NumPy loaded, as the tools pin theirs; its
    # key is the subprocess's even with OpenCV's own OpenBLAS loaded (the simulator imports it).
    if os.environ.get(OPT_OUT, "").lower() != "native":
        import cv2  # noqa: F401

        machine_fingerprint.cache_clear()
        assert machine_fingerprint()["numerics"] == "pinned"
        assert machine_fingerprint()["numeric_key"] == given["fingerprint"]["numeric_key"]


def test_osc_torques_and_goals_match_robosuites_controller() -> None:
    # For the same state, robosuite's own (Numba, LAPACK, BLAS) controller and ours agree to the
    # last bits of their arithmetic; the goal rotation is float32 in both.
    task = get_task("libero_goal/3")
    rng = np.random.default_rng(0)
    worst_torque = worst_ori = worst_pos = 0.0
    with LiberoEnv(task, EnvConfig(cameras=())) as env:
        env.reset(task.init_states()[0], seed=0, settle=5, render=False)
        arm = env._stepper.arms[0]
        c = arm.controller
        robosuite_osc = type(c)
        for _ in range(30):
            action = np.concatenate([rng.uniform(-1, 1, 6), [rng.choice([-1.0, 1.0])]])
            c.update(force=True)
            before = (c.goal_pos.copy(), c.goal_ori.copy())
            arm.osc.set_goal(action[:6])
            ours_goal = (c.goal_pos.copy(), c.goal_ori.copy())
            c.goal_pos, c.goal_ori = before
            robosuite_osc.set_goal(c, action[:6])
            worst_pos = max(worst_pos, float(np.abs(ours_goal[0] - c.goal_pos).max()))
            worst_ori = max(worst_ori, float(np.abs(ours_goal[1] - c.goal_ori).max()))
            ours = arm.osc.torques().copy()
            c.new_update = False
            theirs = robosuite_osc.run_controller(c).copy()
            worst_torque = max(worst_torque, float(np.abs(ours - theirs).max() / np.abs(theirs).max()))
            env.advance(action)
    assert worst_torque < 1e-12, worst_torque
    assert worst_pos < 1e-15, worst_pos
    assert worst_ori < 3e-7, worst_ori  # two float32 ulps of a rotation matrix entry


def test_orientation_error_is_robosuites_bit_for_bit() -> None:
    from robosuite.utils import transform_utils as T
    from robosuite.utils.control_utils import orientation_error

    from libero_data.sim.osc import _orientation_error

    rng = np.random.default_rng(0)
    for _ in range(500):
        a = T.quat2mat(T.axisangle2quat(rng.uniform(-1, 1, 3)))
        b = T.quat2mat(T.axisangle2quat(rng.uniform(-1, 1, 3)))
        np.testing.assert_array_equal(_orientation_error(a, b), orientation_error(a, b))


@pytest.mark.parametrize("tool", ["libero_data.cli", "libero_bench.cli"])
def test_each_tool_pins_its_numeric_path_before_anything_loads_numpy(tool: str) -> None:
    # The entry point imports the package and calls main(): nothing before the pin may load
    # NumPy (a command module reading the kinds' registry for its --help once did, and the run
    # it made took this machine's own kernel).
    script = (
        "import sys\n"
        f"import {tool} as cli\n"
        "assert 'numpy' not in sys.modules, 'importing the tool loaded NumPy'\n"
        "sys.argv = ['tool', '--help']\n"
        "try:\n    cli.main()\nexcept SystemExit:\n    pass\n"
        "from libero_data.numerics import machine_fingerprint\n"
        "print(machine_fingerprint()['numerics'])\n"
    )
    env = {
        k: v
        for k, v in os.environ.items()
        if k not in ("OPENBLAS_CORETYPE", "NPY_DISABLE_CPU_FEATURES", OPT_OUT)
    }
    done = subprocess.run(
        [sys.executable, "-c", script], cwd=ROOT, env=env, capture_output=True, text=True, timeout=300
    )
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.strip().splitlines()[-1] == "pinned"
