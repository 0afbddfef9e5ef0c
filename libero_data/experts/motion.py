"""Turning pose targets into 7-D OSC delta actions, closed loop on privileged state.

Each motion is a generator: it yields one action per control step and reads the arm's pose
again after the environment has stepped. ``yield from`` chains motions into skills.
"""

from __future__ import annotations

from collections.abc import Callable, Generator
from dataclasses import dataclass

import numpy as np

from libero_data.experts.geometry import rotation_error
from libero_data.experts.scene import SceneView

#: OSC_POSE scaling of robosuite's default controller: action 1.0 = 5 cm or 0.5 rad.
POS_SCALE = 0.05
ROT_SCALE = 0.5
CONTROL_DT = 0.05
OPEN, CLOSE = -1.0, 1.0
HOLD = 0.0  # keeps the gripper's current set-point (robosuite integrates the sign of the command)
#: Finger opening lost per control step of closing (robosuite's Panda gripper: 0.01 of its
#: [-1, 1] range per substep, 25 substeps per step, over an 8 cm stroke).
CLOSING_PER_STEP = 0.01
FULL_OPENING = 0.08
#: Descents onto an object and lowerings of a held one go at twice their pace until this far
#: (m) from where they end.
SLOW_BELOW = 0.03

#: Within reach of the set-point, a move asks each step for this many times the remaining error
#: (``gain``): the controller covers about a quarter of what it is asked per step, so at 1 the
#: last centimetres crawled (2 cm to 3 mm took ~7 steps). Lowering a held object onto its spot in
#: 2-step moves keeps 1: at 2 it missed the spot (libero_90/40, /83, libero_10/8).
FINAL_GAIN = 2.0

Actions = Generator[np.ndarray, None, bool]


@dataclass(frozen=True)
class Style:
    """How one demonstration moves: drawn once per episode from the expert's seed."""

    speed: float = 0.35  # m/s of the position set-point in free space
    turn_speed: float = 1.6  # rad/s
    noise: float = 0.0  # std of Gaussian noise on the 6 motion components of each action
    lead: float = 2.2  # how far ahead of the arm the set-point runs, in control steps
    tempo: float = 1.0  # factor on turns and on the fine motions' own speeds (descents, pulls)


class Motion:
    """Action generators for one episode."""

    def __init__(self, scene: SceneView, style: Style, rng: np.random.Generator) -> None:
        self.scene = scene
        self.style = style
        self.rng = rng
        self.gripper = OPEN

    def _action(self, delta_pos: np.ndarray, delta_rot: np.ndarray) -> np.ndarray:
        action = np.zeros(7)
        action[:3] = np.clip(delta_pos / POS_SCALE, -1.0, 1.0)
        action[3:6] = np.clip(delta_rot / ROT_SCALE, -1.0, 1.0)
        if self.style.noise > 0:
            action[:6] += self.rng.normal(0.0, self.style.noise, 6)
            action[:6] = np.clip(action[:6], -1.0, 1.0)
        action[6] = self.gripper
        return action

    def move(
        self,
        pos: np.ndarray,
        mat: np.ndarray | None = None,
        *,
        speed: float | None = None,
        tol: float = 0.006,
        rot_tol: float = 0.06,
        max_steps: int = 120,
        min_steps: int = 0,
        until: Callable[[], bool] | None = None,
        stall: int | None = None,
        gain: float = FINAL_GAIN,
    ) -> Actions:
        """Drive the grip site to ``pos`` (and orientation ``mat``); True when reached.

        For a target beyond what the hand can get to (pressing into the table, pulling a
        drawer past its stop): ``until`` ends the move, True, as soon as it holds (the drawer
        is open), and ``stall`` ends it, False, once that many steps have not brought the hand
        1 mm (or 0.02 rad) closer (the stop is reached, the wrist turns no further here)
        instead of pushing on for ``max_steps``.
        """
        pos = np.asarray(pos, dtype=np.float64)
        v = (self.style.speed if speed is None else speed * self.style.tempo) * CONTROL_DT * self.style.lead
        w = self.style.turn_speed * self.style.tempo * CONTROL_DT * self.style.lead
        closest, since = np.inf, 0
        for step in range(max_steps):
            cur = self.scene.eef_pos()
            err = pos - cur
            dist = float(np.linalg.norm(err))
            rot = np.zeros(3) if mat is None else rotation_error(mat, self.scene.eef_mat())
            angle = float(np.linalg.norm(rot))
            if step >= min_steps and dist < tol and angle < rot_tol:
                return True
            if until is not None and until():
                return True
            remaining = dist + 0.05 * angle  # a radian to turn counts as 5 cm to go
            if remaining < closest - 0.001:
                closest, since = remaining, 0
            else:
                since += 1
                if stall is not None and since >= stall:
                    return False
            dp = err * gain if dist * gain <= v else err / dist * v
            dr = rot if angle <= w else rot / angle * w
            yield self._action(dp, dr)
        return False

    def path(self, waypoints: list[np.ndarray], mat: np.ndarray | None = None, **kw: float) -> Actions:
        """Pass through waypoints (loosely), ending at the last one."""
        ok = True
        for i, point in enumerate(waypoints):
            last = i == len(waypoints) - 1
            tol = kw.get("tol", 0.006) if last else 0.02
            ok = yield from self.move(
                point, mat, tol=tol, rot_tol=0.06 if last else 0.25, speed=kw.get("speed")
            )
        return ok

    def hold(self, steps: int, mat: np.ndarray | None = None, pos: np.ndarray | None = None) -> Actions:
        """Stay in place for ``steps`` control steps."""
        target = self.scene.eef_pos() if pos is None else np.asarray(pos)
        for _ in range(steps):
            rot = np.zeros(3) if mat is None else rotation_error(mat, self.scene.eef_mat())
            yield self._action(target - self.scene.eef_pos(), rot)
        return True

    def set_gripper(self, value: float, steps: int = 10, mat: np.ndarray | None = None) -> Actions:
        """Close (+1) or open (-1) the gripper while holding the pose."""
        self.gripper = value
        return (yield from self.hold(steps, mat))

    def preshape(self, opening: float, mat: np.ndarray | None = None) -> Actions:
        """Close a fully open gripper to about ``opening`` (1-cm steps) and keep it there.

        The following motions send the gripper command 0 (hold) until the next open or close.
        """
        yield from self.set_gripper(OPEN, steps=2, mat=mat)  # its set-point is fully open again
        steps = max(round((FULL_OPENING - opening) / CLOSING_PER_STEP), 0)
        yield from self.set_gripper(CLOSE, steps=steps, mat=mat)
        return (yield from self.set_gripper(HOLD, steps=3, mat=mat))
