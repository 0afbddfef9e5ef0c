"""Physics cost of a control step (no cameras): ours against LIBERO's own ``env.step``.

This is what searching for demonstrations, the expert report and ``validate --resimulate``
spend their time on. Per task, in one process, taking turns round by round (so a change in
the machine's load hits every measurement alike), each the median of ``--reps`` rounds of
``--steps`` control steps of the same seeded random actions from the same state:

- **LIBERO**: LIBERO's own ``env.step`` (robosuite's step: ``mj_forward`` + controller +
  ``mj_step`` per substep, observations, LIBERO's reward and goal check) on an environment
  this toolkit has not touched;
- **ours**: ``LiberoEnv.advance`` (``ControlStepper``'s step and one goal check), the call
  the expert makes;
- **MuJoCo**: ``mj_step1`` + ``mj_step2`` for the same 25 substeps with nothing else, the
  floor (the arm's controller has to run in between, so no step reaches it).

Ours evaluates robosuite's OSC equations off BLAS (``libero_data/sim/osc.py``), so its states
follow LIBERO's step to the last bits of that arithmetic (within 1e-6 m or rad over 40 steps:
``tests/sim/test_env.py``) and are the same on any x86-64 machine.
Prints a Markdown table and, with ``--results``, replaces this benchmark's section of
``benchmarks/RESULTS.md``.
"""

from __future__ import annotations

import argparse
import os
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np

from benchmarks.bench_render import interleaved_rates

DEFAULT_TASKS = ["libero_goal/0", "libero_10/9", "libero_90/40"]


def measure(task_ref: str, steps: int, reps: int, seed: int) -> dict[str, float]:
    import mujoco

    from libero_data.sim import EnvConfig, LiberoEnv
    from libero_data.tasks import get_task

    class Untouched(LiberoEnv):  # LIBERO's env exactly as LIBERO builds and steps it
        def _trim_step(self) -> None:
            pass

        def _physics_step(self, action: np.ndarray) -> None:
            self._env.step(action)

    task = get_task(task_ref)
    rng = np.random.default_rng(seed)
    actions = rng.uniform(-0.4, 0.4, (steps, 7))
    actions[:, 6] = np.where(np.arange(steps) < steps // 2, -1.0, 1.0)
    with LiberoEnv(task, EnvConfig(cameras=())) as ours, Untouched(task, EnvConfig(cameras=())) as theirs:
        for env in (ours, theirs):
            env.reset(task.init_states()[0], seed=seed, settle=20, render=False)
        start_ours, start_theirs = ours.get_state(), theirs.get_state()
        model, data = ours.sim.model._model, ours.sim.data._data
        substeps = ours._stepper.substeps

        def run(step) -> None:
            for a in actions:
                step(a)

        def floor() -> None:
            for _ in range(steps * substeps):
                mujoco.mj_step1(model, data)
                mujoco.mj_step2(model, data)

        rates = interleaved_rates(
            {
                "libero": lambda: run(theirs.advance),
                "ours": lambda: run(ours.advance),
                "mujoco": floor,
            },
            {
                "libero": lambda: theirs.set_state(start_theirs),
                "ours": lambda: ours.set_state(start_ours),
                "mujoco": lambda: ours.set_state(start_ours),
            },
            1,
            reps,
        )
    return {name: seconds / steps for name, seconds in rates.items()}


def mujoco_step_ms(task_ref: str = "libero_object/0", steps: int = 200) -> float:
    """Milliseconds of MuJoCo's own step (``mj_step1`` + ``mj_step2``) per control step of
    ``task_ref`` (its 25 substeps, nothing else): this machine's speed at what the tests and the
    expert spend their time on, printed beside the test suite's time (``tests/conftest.py``) so
    that a suite's time on another machine can be set against it. About 3 s."""
    import time

    import mujoco

    from libero_data.sim import EnvConfig, LiberoEnv
    from libero_data.tasks import get_task

    task = get_task(task_ref)
    with LiberoEnv(task, EnvConfig(cameras=())) as env:
        env.reset(task.init_states()[0], seed=0, settle=20, render=False)
        model, data = env.sim.model._model, env.sim.data._data
        substeps = env._stepper.substeps
        best = float("inf")
        for _ in range(3):  # the fastest of three rounds: what the machine can do, not its load
            started = time.perf_counter()
            for _ in range(steps * substeps):
                mujoco.mj_step1(model, data)
                mujoco.mj_step2(model, data)
            best = min(best, (time.perf_counter() - started) / steps)
    return best * 1e3


def table(results: dict[str, dict[str, float]], steps: int, reps: int) -> str:
    lines = [
        f"Per control step (20 Hz, 25 substeps), no cameras; medians of {reps} rounds × {steps} steps "
        "of seeded random actions taking turns, one process.",
        "",
        "| task | LIBERO `env.step` ms | ours `LiberoEnv.advance` ms | speed-up | MuJoCo alone ms |",
        "|---|---:|---:|---:|---:|",
    ]
    for task, r in results.items():
        lines.append(
            f"| `{task}` | {r['libero'] * 1e3:.2f} | {r['ours'] * 1e3:.2f} | "
            f"{r['libero'] / r['ours']:.2f}× | {r['mujoco'] * 1e3:.2f} |"
        )
    lines += [
        "",
        "Ours evaluates robosuite's OSC equations on every substep with MuJoCo's own linear algebra "
        "(Cholesky solves instead of robosuite's LU inverse and three SVD pseudo-inverses, "
        "`libero_data/sim/osc.py`: the same torques on any CPU), and leaves out a second forward "
        "pass per substep, name lookups, observations nobody reads and LIBERO's reward "
        "(`libero_data/sim/stepper.py`). The rest of our step above the MuJoCo column is that "
        "controller and the goal check.",
    ]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--tasks", nargs="+", default=DEFAULT_TASKS, help="Tasks to measure.")
    parser.add_argument("--steps", type=int, default=100, help="Control steps per round.")
    parser.add_argument("--reps", type=int, default=5, help="Rounds per measurement (median).")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--results", type=Path, help="RESULTS.md to update.")
    args = parser.parse_args(argv)
    results = {t: measure(t, args.steps, args.reps, args.seed) for t in args.tasks}
    text = table(results, args.steps, args.reps)
    print(text)
    if args.results:
        from benchmarks.results import replace_section

        replace_section(args.results, "Physics", text)


if __name__ == "__main__":
    main()
