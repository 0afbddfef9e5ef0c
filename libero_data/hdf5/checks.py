"""What an import measures of each demonstration: how its states replay under our simulator,
which stored init state it began nearest to, and which of its frames are no-ops."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

#: A frame is a no-op when its arm command (the six OSC deltas) is below this in every
#: component and its gripper command equals the frame before's: the arm does not move and the
#: gripper does not change (policies trained on LIBERO's raw data learn to stall on such frames).
NOOP_ARM = 1e-4


def noop_frames(actions: np.ndarray) -> np.ndarray:
    """Boolean mask of the no-op frames of an episode's actions (see :data:`NOOP_ARM`)."""
    actions = np.asarray(actions, dtype=np.float64)
    still = np.all(np.abs(actions[:, :6]) < NOOP_ARM, axis=1)
    previous = np.concatenate([[actions[0, 6]], actions[:-1, 6]])
    return still & (actions[:, 6] == previous)


@dataclass(frozen=True)
class StepReplay:
    """Each stored state restored, its action stepped, the result against the next stored state."""

    #: Per step t (0..T-2): the largest |position| difference (joints and objects, m or rad)
    #: between stepping from state t and the stored state t+1.
    deviations: np.ndarray
    #: The state after the last action (stepped from the last stored state).
    final_state: np.ndarray

    @property
    def worst(self) -> float:
        return float(self.deviations.max()) if self.deviations.size else 0.0

    @property
    def mean(self) -> float:
        return float(self.deviations.mean()) if self.deviations.size else 0.0


def step_replay(
    env: Any, states: np.ndarray, actions: np.ndarray, frames: np.ndarray | None = None
) -> StepReplay:
    """Step every stored state's action from that state and compare with the next stored state.

    The gripper's command ramp (which a stored state does not hold) is carried from step to
    step as the demonstration built it, so a closed hand is not restored as opening. One-step
    deviations do not add up over the episode as an open-loop replay's do: they measure whether
    the states are what this simulator makes of the actions, not how chaotic contact is.
    ``frames`` (each frame's index in the demonstration as recorded) skips the comparison
    across frames dropped in between (no-op frames an import left out).
    """
    from libero_data.sim.stepper import resting_open

    gripper = env.raw.robots[0].gripper
    positions = slice(1, 1 + int(env.sim.model.nq))  # flat state: (time, qpos, qvel)
    ramp = resting_open(gripper)
    deviations = np.zeros(max(len(actions) - 1, 0))
    for t in range(len(actions)):
        env.set_state(states[t])
        gripper.current_action = ramp.copy()
        env.advance(actions[t])
        ramp = np.array(gripper.current_action, copy=True)
        if t + 1 < len(actions) and (frames is None or frames[t + 1] == frames[t] + 1):
            deviations[t] = np.abs(env.get_state()[positions] - states[t + 1][positions]).max()
    return StepReplay(deviations, env.get_state())


#: A demonstration began from a stored init state when its first kept state (LIBERO keeps it
#: 5 steps in) has every object within this (m, horizontally) of where that init state puts
#: the objects after 5 steps of its own (arm still): stored init states hold objects a few cm
#: above their supports, and in those steps they drop and may slide a few mm, about as far as
#: two of a task's 50 init states lie apart (a median of 5-12 mm, task by task), so they are
#: compared after the same 5 steps.
START_MATCH = 0.005


def object_positions(env: Any, state: np.ndarray) -> np.ndarray:
    """The horizontal position (x, y) of every free-moving body in a flattened state (the
    objects, not the arm or the fixtures' doors and drawers)."""
    import mujoco

    model = env.sim.model._model
    rows = [
        int(model.jnt_qposadr[j]) + 1 + np.arange(2)
        for j in range(model.njnt)
        if model.jnt_type[j] == mujoco.mjtJoint.mjJNT_FREE
    ]
    index = np.concatenate(rows) if rows else np.zeros(0, dtype=int)
    return np.asarray(state)[index]


#: How many stored init states, nearest before stepping, :func:`nearest_init` advances: the 5
#: steps move an object a few mm at most, less than most init states lie apart, so the nearest
#: after them is among the few nearest before (50 init states stepped would cost 250 steps per
#: demonstration; these cost 25).
SHORTLIST = 5


def nearest_init(
    env: Any, state: np.ndarray, stored: np.ndarray, steps: int, shortlist: int = SHORTLIST
) -> tuple[int, float]:
    """The stored init state whose objects, ``steps`` steps on with the arm still, stand nearest
    to ``state``'s, and how far (the largest horizontal coordinate difference of one object, m).
    Only the ``shortlist`` init states nearest before stepping are stepped. The scene's fixtures
    must stand where the demonstration had them."""
    from libero_data.sim.env import NOOP_ACTION

    mine = object_positions(env, state)
    if not mine.size:
        return 0, 0.0
    before = [float(np.abs(object_positions(env, init) - mine).max()) for init in stored]
    gaps: dict[int, float] = {}
    for i in np.argsort(before, kind="stable")[:shortlist]:
        env.set_state(stored[i])
        for _ in range(steps):
            env.advance(NOOP_ACTION)
        gaps[int(i)] = float(np.abs(object_positions(env, env.get_state()) - mine).max())
    best = min(gaps, key=lambda i: (gaps[i], i))
    return best, gaps[best]
