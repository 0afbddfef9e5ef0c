"""LIBERO's own evaluation loop, episode for episode: what openpi's LIBERO client and the papers
that report LIBERO success with it see.

That loop (openpi's ``examples/libero/main.py``; OpenVLA-OFT's is the same) builds LIBERO's
``OffScreenRenderEnv`` for a task, seeds NumPy's global generator with ``env.seed(7)`` once, and
then for episode ``i``: ``env.reset()`` (a hard reset: the scene's model is built again and the
fixtures, cabinets and stoves, are placed from NumPy's global generator), ``set_init_state`` of
stored init state ``i``, 10 steps of ``[0, 0, 0, 0, 0, 0, -1]``, then the policy's actions until
``done`` or the step limit. :class:`LiberoLoop` gives the same observations, state for state and
pixel for pixel, from one :class:`~libero_data.sim.env.LiberoEnv`, without rebuilding the model:

- **Fixtures.** Episode ``i``'s fixtures depend on every reset before it. A reset here is a soft
  one, made to consume NumPy's generator as LIBERO's hard reset does: the fixtures' bodies go back
  to the model's own placement first (a hard reset builds the model anew), the gripper's command
  ramp back to zero (a new gripper model), and LIBERO's list of articulated-object samplers gets
  the length it has after that many hard resets (LIBERO appends to it on every model build, so its
  ``n``-th hard reset draws ``n + 1`` times per sampler). The generator's state before each
  episode is replayed once per task (milliseconds a reset, images off) and kept, so any worker
  can run any episode.
- **Start.** LIBERO's ``set_init_state``: the state is written and the observables updated, but the
  arm controller keeps the pose it read at the reset, so the first steps pull the end effector a
  few millimetres (LIBERO's own behaviour, which :meth:`LiberoEnv.set_state` removes).
- **Steps.** robosuite's own ``env.step`` (not :class:`~libero_data.sim.stepper.ControlStepper`):
  LIBERO's arithmetic to the last bit, and ``done`` as LIBERO evaluates it.
- **Observations.** robosuite samples every observable once per control step, at the substep its
  clock falls due, which is not the last one: the state and both camera images a policy gets
  are those of that substep. The cameras are observables here too (drawn by the environment's
  renderer, ``full`` or ``fast``), so they are drawn at the same substep as LIBERO's.
  ``state`` is LIBERO's 8-D state as openpi's client builds it: end-effector position,
  robosuite's ``quat2axisangle`` of the quaternion as LIBERO returns it (angle in [0, 2π): no
  sign folding), gripper finger positions, in float64.
- **Images only where a policy looks.** LIBERO draws both cameras at every step, but a client that
  executes chunks looks at one observation in each chunk. A step told not to ``render`` keeps its
  cameras' clocks as they are and hands back the images drawn last (drawing changes no state, so
  every image that is drawn is LIBERO's, pixel for pixel); the waiting steps draw only the last.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from libero_data.sim.env import LiberoEnv

#: openpi's seed of LIBERO's environment (``env.seed(7)``), once per task.
LIBERO_LOOP_SEED = 7
#: openpi's waiting action: no motion, gripper open.
WAIT_ACTION = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, -1.0)
_IMAGES = {"agentview": "libero_loop_agentview", "eye_in_hand": "libero_loop_eye_in_hand"}


def libero_axis_angle(quat_xyzw: np.ndarray) -> np.ndarray:
    """Axis-angle of a quaternion (x, y, z, w) as robosuite's ``quat2axisangle`` computes it: the
    quaternion's sign is kept, so the angle is in [0, 2π) and a rotation near π does not jump
    between two opposite vectors as its quaternion's w crosses zero (LIBERO's gripper-down pose)."""
    q = np.array(quat_xyzw, dtype=np.float64)
    w = min(1.0, max(-1.0, float(q[3])))
    den = np.sqrt(1.0 - w * w)
    if math.isclose(den, 0.0):
        return np.zeros(3)
    return np.asarray((q[:3] * 2.0 * math.acos(w)) / den, dtype=np.float64)


class LiberoLoop:
    """LIBERO's evaluation loop on ``env`` (see the module docstring); ``seed`` is the loop's seed
    of NumPy's generator (openpi's 7). Episode ``i`` starts from the stored init state the caller
    gives with the fixtures LIBERO's ``i``-th reset places."""

    def __init__(self, env: LiberoEnv, seed: int = LIBERO_LOOP_SEED) -> None:
        self.env = env
        self.seed = seed
        raw = env.raw
        # The placement a hard reset starts from.
        self._fixture_bodies, self._fixture_pos, self._fixture_quat = env.fixture_home()
        self._property_samplers = list(raw.object_property_initializers)
        self._builds = 1  # model builds so far in LIBERO's loop: the environment's construction
        self._before: list[tuple[Any, int]] = []  # per episode: (NumPy state, model builds) before its reset
        self._after: tuple[Any, int] | None = None
        self._draw = True  # whether the cameras draw at this step's sampling (else: their last images)
        self._last: dict[str, np.ndarray] = {}
        self._add_cameras()

    def _add_cameras(self) -> None:
        from robosuite.utils.observables import Observable, sensor

        env = self.env
        for camera, name in _IMAGES.items():
            if camera not in env.config.cameras:
                continue

            @sensor(modality="image")
            def image(obs_cache: Any, _camera: str = camera) -> np.ndarray:
                if self._draw or _camera not in self._last:
                    self._last[_camera] = env.render(_camera)
                return self._last[_camera]

            env.raw.add_observable(Observable(name, image, sampling_rate=env.config.control_freq))

    # episodes -------------------------------------------------------------------------------
    def reset(self, init_state: np.ndarray, episode: int, *, settle: int = 10) -> dict[str, Any]:
        """Episode ``episode``: LIBERO's reset and ``set_init_state``, then ``settle`` waiting steps
        (their ``done`` ignored, as openpi's client does); the observation the policy acts on."""
        rng, builds = self._replay(episode)
        saved = np.random.get_state()
        np.random.set_state(rng)
        self._draw = False  # nobody looks at the images of the reset, the start and the first waits
        try:
            self._libero_reset(builds)
            raw = self.env.raw
            raw.sim.set_state_from_flattened(np.asarray(init_state, dtype=np.float64))
            raw.sim.forward()
            raw._check_success()
            raw._post_process()
            self._draw = settle == 0
            raw._update_observables(force=True)
            obs = self.observe()
            for wait in range(settle):
                obs, _done = self.step(np.asarray(WAIT_ACTION), render=wait == settle - 1)
        finally:
            np.random.set_state(saved)
            self._draw = True
        return obs

    def step(self, action: np.ndarray, *, render: bool = True) -> tuple[dict[str, Any], bool]:
        """robosuite's step through LIBERO (its arithmetic and its ``done``); without ``render`` the
        observation holds the images drawn last."""
        self._make_current()
        self._draw = render
        try:
            _obs, _reward, done, _info = self.env.raw.step(np.asarray(action, dtype=np.float64))
        finally:
            self._draw = True
        return self.observe(), bool(done)

    def observe(self) -> dict[str, Any]:
        """The observation LIBERO returned last (sampled at its observables' substep)."""
        raw = self.env.raw._get_observations()
        pos = np.array(raw["robot0_eef_pos"], dtype=np.float64)
        quat = np.array(raw["robot0_eef_quat"], dtype=np.float64)
        gripper = np.array(raw["robot0_gripper_qpos"], dtype=np.float64)
        obs: dict[str, Any] = {
            "state": np.concatenate([pos, libero_axis_angle(quat), gripper]),
            "joint_pos": np.array(raw["robot0_joint_pos"], dtype=np.float64),
            "gripper_state": gripper,
            "eef_pos": pos,
            "eef_quat": quat,
            "object_poses": self.env.object_poses(),
            "sim_state": self.env.get_state(),
        }
        for camera, name in _IMAGES.items():
            if name in raw:
                obs[camera] = np.asarray(raw[name])
        if self.env.perturbation is not None:  # a variant's image or state noise, as LiberoEnv applies it
            from libero_data.perturb.apply import observe

            observe(obs, self.env.perturbation, tuple(c for c in _IMAGES if c in obs))
        return obs

    # LIBERO's resets --------------------------------------------------------------------------
    def _libero_reset(self, builds: int) -> int:
        """One ``env.reset()`` of LIBERO's wrapper (it tries again while objects do not fit) as the
        ``builds``-th model build would run it; the builds after it."""
        from robosuite.utils.errors import RandomizationError

        raw = self.env.raw
        self._make_current()
        while True:
            builds += 1
            raw.sim.model.body_pos[self._fixture_bodies] = self._fixture_pos
            raw.sim.model.body_quat[self._fixture_bodies] = self._fixture_quat
            raw.object_property_initializers = self._property_samplers * builds
            for robot in raw.robots:
                if robot.has_gripper:
                    robot.gripper.current_action = np.zeros(robot.gripper.dof)
            try:
                raw.reset()
                return builds
            except RandomizationError:
                continue

    def _replay(self, episode: int) -> tuple[Any, int]:
        """NumPy's state and the model builds before episode ``episode``'s reset (replayed once)."""
        if episode < 0:
            raise ValueError(f"episode must be at least 0, got {episode}")
        if len(self._before) <= episode:
            saved = np.random.get_state()
            self._draw = False  # replaying draws no images
            try:
                if self._after is None:
                    np.random.seed(self.seed)
                    self._after = (np.random.get_state(), self._builds)
                while len(self._before) <= episode:
                    state, builds = self._after
                    self._before.append((state, builds))
                    np.random.set_state(state)
                    builds = self._libero_reset(builds)
                    self._after = (np.random.get_state(), builds)
            finally:
                self._draw = True
                np.random.set_state(saved)
        return self._before[episode]

    def close(self) -> None:
        self.env.close()

    def _make_current(self) -> None:
        context = getattr(self.env.raw.sim, "_render_context_offscreen", None)
        if context is not None:  # another environment in this process may have made its context current
            context.gl_ctx.make_current()
