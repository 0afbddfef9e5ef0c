"""A headless LIBERO environment for any task: a suite task or any BDDL file on disk.

This is the only module family that imports robosuite and LIBERO; it does so when an
environment is created, never at import time.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from libero_data.bddl import And, Atom, Formula, Not, Or, Problem, parse_file
from libero_data.config import Config
from libero_data.errors import BDDLError, InputError, MissingFileError, SceneError
from libero_data.sim.arm import ARM_INIT_NOISE, check_arm_noise, jitter_arm
from libero_data.sim.gl import gl_strings, select_backend
from libero_data.sim.imports import import_libero
from libero_data.sim.rotations import quat_to_axis_angle, wxyz_to_xyzw
from libero_data.sim.stepper import resting_open

if TYPE_CHECKING:
    from libero_data.sim.fast.images import FastImages
    from libero_data.tasks import Task

log = logging.getLogger(__name__)

#: Our camera names -> robosuite camera names.
CAMERAS: dict[str, str] = {"agentview": "agentview", "eye_in_hand": "robot0_eye_in_hand"}
ACTION_DIM = 7
#: How images are drawn: ``full`` is LIBERO's renderer, pixel for pixel; ``fast`` draws simplified
#: visual meshes (libero_data.sim.fast), held close to ``full`` by tests and in every dataset.
RENDER_QUALITIES = ("full", "fast")
#: Zero motion, gripper open.
NOOP_ACTION = np.array([0.0, 0.0, 0.0, 0.0, 0.0, 0.0, -1.0])
STATE_DIM = 8


def check_render_quality(value: str) -> None:
    """Raise :class:`InputError` unless ``value`` is one of :data:`RENDER_QUALITIES`."""
    if value not in RENDER_QUALITIES:
        raise InputError(
            f"render quality must be {' or '.join(RENDER_QUALITIES)}, got {value!r}", field="render_quality"
        )


@dataclass(frozen=True)
class EnvConfig(Config):
    """How an environment is built.

    ``cameras`` may be empty: no renderer is created and stepping costs physics only, which
    is what searching for demonstrations wants. ``renderer`` is ``"egl"``, ``"osmesa"`` or
    ``None`` (``$MUJOCO_GL``, else the first available). ``render_quality`` is ``"full"``
    (LIBERO's images, pixel for pixel) or ``"fast"`` (simplified visual meshes, cached under
    ``mesh_cache``, default ``$LIBERO_DATA_CACHE`` or the user's cache folder).
    """

    image_size: int = 128
    cameras: tuple[str, ...] = ("agentview", "eye_in_hand")
    renderer: str | None = None
    control_freq: int = 20
    render_quality: str = "full"
    mesh_cache: str | None = None
    arm_noise: float = ARM_INIT_NOISE  # rad per joint on sampler starts, as LIBERO's stored states

    def __post_init__(self) -> None:
        check_arm_noise(self.arm_noise)
        if not 16 <= self.image_size <= 2048:
            raise InputError(f"the image size must be in 16..2048, got {self.image_size}", field="image_size")
        if self.control_freq <= 0:
            raise InputError(f"control_freq must be positive, got {self.control_freq}", field="control_freq")
        if len(set(self.cameras)) != len(self.cameras):
            raise InputError(f"cameras must not repeat: {self.cameras}", field="cameras")
        check_render_quality(self.render_quality)


class LiberoEnv:
    """The real LIBERO scene of one task, simulated headless with 7-D OSC delta actions.

    Observations (``observe``/``reset``/``step``) are a dict with:

    - one upright ``uint8`` image ``(H, W, 3)`` per configured camera (``agentview``,
      ``eye_in_hand``);
    - ``state`` (8): end-effector position (3), axis-angle (3), gripper finger qpos (2);
    - ``joint_pos`` (7), ``gripper_state`` (2), ``eef_pos`` (3), ``eef_quat`` (4, x y z w);
    - ``object_poses``: name -> ``[x, y, z, qx, qy, qz, qw]`` for every object and fixture;
    - ``sim_state``: the flattened MuJoCo state (time, qpos, qvel), enough to restore the frame.

    ``reset(init_state, seed)`` is reproducible: fixture placement (which LIBERO re-samples
    on every reset) is drawn from ``seed``, so the same pair gives the same scene.
    """

    def __init__(self, task: Task | str | Path, config: EnvConfig | None = None) -> None:
        self.config = config or EnvConfig()
        unknown = [c for c in self.config.cameras if c not in CAMERAS]
        self.bddl_path, self.task = _resolve(task)
        self.problem: Problem = self.task.problem if self.task is not None else parse_file(self.bddl_path)
        self.language = self.task.language if self.task is not None else self.problem.language
        self.backend = select_backend(self.config.renderer) if self.config.cameras else None
        self._gl_info: dict[str, str] | None = None
        self._home: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None
        self.perturbation = _perturbation_of(self.problem.perturbation)
        if self.perturbation is not None:
            from libero_data.perturb import apply as hooks

            hooks.prepare_build(self.perturbation)
        self._env = self._build()
        self._trim_step()
        self.fast_images: FastImages | None = None  # render_quality="fast": its renderers (tests, benchmarks)
        if self.perturbation is not None:
            hooks.apply_scene(self._env, self.perturbation)
        model_cameras = set(self._env.sim.model.camera_names)
        for name in unknown:
            if name not in model_cameras:
                self.close()
                raise InputError(
                    f"unknown camera {name!r}; choose from {sorted(CAMERAS)} or {sorted(model_cameras)}",
                    field="cameras",
                )
        if self.config.cameras and self.config.render_quality == "fast":
            from libero_data.sim.fast.images import FastImages

            ids = [self.camera_id(c) for c in self.config.cameras]
            self.fast_images = FastImages(self.config.image_size, ids, self.backend, self.config.mesh_cache)
        self._closed = False

    # construction ---------------------------------------------------------------------
    def _build(self) -> Any:
        robosuite, TASK_MAPPING = import_libero()

        key = self.problem.problem.lower()
        if key not in TASK_MAPPING:
            known = ", ".join(sorted(TASK_MAPPING))
            raise BDDLError(
                f"unknown LIBERO problem {self.problem.problem!r} (known: {known})",
                source=str(self.bddl_path),
            )
        # With "fast" images robosuite's renderer is never used (ours draws them).
        cameras = bool(self.config.cameras) and self.config.render_quality == "full"
        return TASK_MAPPING[key](
            bddl_file_name=str(self.bddl_path),
            robots=["Panda"],
            controller_configs=robosuite.load_controller_config(default_controller="OSC_POSE"),
            gripper_types="default",
            initialization_noise=None,
            use_camera_obs=False,  # images are rendered by observe(), only when asked
            has_renderer=False,
            has_offscreen_renderer=cameras,
            render_camera=None,
            render_gpu_device_id=-1,
            control_freq=self.config.control_freq,
            horizon=1_000_000,
            ignore_done=True,
            hard_reset=False,  # a hard reset rebuilds model, simulation and renderer at every reset
            camera_names=[],
            camera_heights=self.config.image_size,
            camera_widths=self.config.image_size,
        )

    # properties -----------------------------------------------------------------------
    @property
    def sim(self) -> Any:
        """robosuite's ``MjSim`` (privileged access for experts and tests)."""
        return self._env.sim

    @property
    def raw(self) -> Any:
        """The underlying LIBERO/robosuite environment."""
        return self._env

    @property
    def state_dim(self) -> int:
        return int(self._env.sim.get_state().flatten().shape[0])

    @property
    def object_names(self) -> list[str]:
        return [o.name for o in self.problem.objects]

    @property
    def fixture_names(self) -> list[str]:
        return [f.name for f in self.problem.fixtures]

    # episode control --------------------------------------------------------------------
    def reset(
        self,
        init_state: np.ndarray | None = None,
        *,
        seed: int = 0,
        render: bool = True,
        settle: int = 0,
    ) -> dict[str, Any]:
        """Reset the scene; fixtures are placed from ``seed``, objects from ``init_state``.

        Without ``init_state`` LIBERO's own sampler places the objects from ``seed``, and the arm's
        joints get the noise LIBERO's stored init states have (:mod:`libero_data.sim.arm`). ``settle``
        no-op steps follow (stored states hold objects a little above their supports; ~20 let them
        rest). The returned state is canonical (:meth:`set_state`): an episode replays exactly.
        """
        from robosuite.utils.errors import RandomizationError

        saved = np.random.get_state()  # LIBERO samples from NumPy's global generator
        np.random.seed(seed)
        bodies, pos, quat = self.fixture_home()
        try:
            for _attempt in range(100):
                # LIBERO puts an object on a fixture at the fixture's new placement plus its site
                # as the model has it: a soft reset puts the fixtures back first (libero_spatial/7's
                # bowl fell on the floor without).
                self._env.sim.model.body_pos[bodies] = pos
                self._env.sim.model.body_quat[bodies] = quat
                try:
                    self._env.reset()
                    break
                except RandomizationError:
                    continue
            else:
                raise SceneError(f"{self.bddl_path}: LIBERO could not place the objects in 100 attempts")
        finally:
            np.random.set_state(saved)
        self._trim_step()  # robosuite builds new controllers on every reset
        if init_state is None:
            jitter_arm(self._env, seed, self.config.arm_noise)
        self.set_state(self.get_state() if init_state is None else init_state)
        if self.perturbation is not None:
            from libero_data.perturb.apply import start_robot

            if start_robot(self._env, self.perturbation, seed):
                self.set_state(self.get_state())
        if settle:
            for _ in range(settle):
                self._physics_step(NOOP_ACTION)
            self.set_state(self.get_state())
        return self.observe(render=render)

    def fixture_home(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The fixtures' root bodies and the placement (positions, quaternions) the scene's model
        gives them before any reset: where LIBERO's hard reset starts from."""
        if self._home is None:
            import mujoco

            model = self._env.sim.model
            bodies = np.asarray(
                [model.body_name2id(f.root_body) for f in self._env.fixtures_dict.values()], dtype=np.intp
            )
            fresh = mujoco.MjModel.from_xml_string(self._env.model.get_xml())
            self._home = (bodies, np.array(fresh.body_pos[bodies]), np.array(fresh.body_quat[bodies]))
        return self._home

    def get_state(self) -> np.ndarray:
        """The flattened MuJoCo state (time, qpos, qvel) of the current frame."""
        return np.asarray(self._env.sim.get_state().flatten(), dtype=np.float64)

    def set_state(self, state: np.ndarray) -> None:
        """Restore a flattened MuJoCo state (as stored in init states and datasets); the rest that
        shapes the next steps is made canonical (gripper ramp open, solver warm start cleared,
        controller re-reads the pose), so the same state and actions give the same trajectory."""
        state = np.asarray(state, dtype=np.float64).reshape(-1)
        if state.shape[0] != self.state_dim:
            raise ValueError(
                f"state has {state.shape[0]} values but this task's MuJoCo state has {self.state_dim}"
            )
        if not np.all(np.isfinite(state)):
            raise ValueError("state contains NaN or infinite values")
        sim = self._env.sim
        sim.set_state_from_flattened(state)
        sim.data.qacc_warmstart[:] = 0.0
        for robot in self._env.robots:
            # The controller caches the arm's pose and Jacobians; make it re-read them.
            robot.controller.new_update = True
            # robosuite ramps the finger command a little every substep; "open" is the ramp's
            # resting value after any stretch of open commands.
            robot.gripper.current_action = resting_open(robot.gripper)
        sim.forward()
        self._env._post_process()
        self._env._update_observables(force=True)

    def step(self, action: np.ndarray, *, render: bool = True) -> tuple[dict[str, Any], bool]:
        """Apply one 7-D action (OSC delta pose in [-1, 1] + gripper); return (obs, success)."""
        ok = self.advance(action)
        return self.observe(render=render), ok

    def advance(self, action: np.ndarray) -> bool:
        """Apply one action and return whether the goal holds, building no observation: the same
        physics as :meth:`step`, bit for bit, for searching where observations are thrown away."""
        action = np.asarray(action, dtype=np.float64).reshape(-1)
        if action.shape[0] != ACTION_DIM or not np.all(np.isfinite(action)):
            raise ValueError(f"action must be {ACTION_DIM} finite numbers, got {action!r}")
        self._physics_step(action)
        return self.success()

    def _physics_step(self, action: np.ndarray) -> None:
        # robosuite's control step as ControlStepper runs it (the same states, bit for bit),
        # without LIBERO's wrapper around it (which evaluates the goal a second time for its
        # ``done`` flag; the reward is switched off by _trim_step).
        self._stepper.step(action)

    def _trim_step(self) -> None:
        """Remove work from robosuite's control step that never changes its result: the 25
        substeps with one forward pass each (:class:`~libero_data.sim.stepper.ControlStepper`)
        and LIBERO's per-step reward (success is evaluated once, by :meth:`success`). Per
        instance, bit for bit the same states (tested); again after every reset."""
        from libero_data.sim.stepper import ControlStepper

        env = self._env
        env.reward = _zero_reward
        self._stepper = ControlStepper(env)

    # observations -----------------------------------------------------------------------
    def render(self, camera: str) -> np.ndarray:
        """One upright RGB image from ``camera`` at the configured size and render quality."""
        if not self.config.cameras:
            raise RuntimeError("this environment was built without cameras (EnvConfig.cameras=())")
        if self.fast_images is not None:
            return self.fast_images.render(self.sim.model._model, self.sim.data._data, self.camera_id(camera))
        size = self.config.image_size
        sim = self._env.sim
        # robosuite renders into whichever OpenGL context is current, and creating another
        # environment makes that one's context current: without this, a second environment
        # in the same process silently turns this one's images into a mix of both scenes.
        sim._render_context_offscreen.gl_ctx.make_current()
        image = sim.render(width=size, height=size, camera_name=CAMERAS.get(camera, camera))
        # MuJoCo reads pixels bottom-up and LIBERO's cameras are mounted rolled by 180 degrees:
        # rotating by 180 degrees gives the upright view (as LeRobot's LIBERO processing does).
        return np.ascontiguousarray(image[::-1, ::-1])

    def render_full(self, camera: str) -> np.ndarray:
        """``camera``'s image at full quality (LIBERO's pixels), whatever the render quality: the
        reference that ``fast`` images are measured against."""
        fast = self.fast_images
        if fast is None:
            return self.render(camera)
        return fast.render_full(self.sim.model._model, self.sim.data._data, self.camera_id(camera))

    def render_scene(self) -> dict[str, Any]:
        """How images are drawn: the quality, and for ``fast`` the triangles drawn and settings."""
        return {"quality": "full"} if self.fast_images is None else self.fast_images.info()

    def camera_id(self, camera: str) -> int:
        """The MuJoCo id of ``camera`` (our name or robosuite's)."""
        return int(self.sim.model.camera_name2id(CAMERAS.get(camera, camera)))

    def gl_info(self) -> dict[str, str] | None:
        """The OpenGL vendor, renderer and version that draw this environment's images (``None``
        without cameras): images depend on it, so datasets record it beside the numeric fingerprint."""
        if not self.config.cameras:
            return None
        if self._gl_info is None and self.fast_images is not None:
            self._gl_info = self.fast_images.gl_info(self.sim.model._model)
        if self._gl_info is None:
            self._env.sim._render_context_offscreen.gl_ctx.make_current()
            self._gl_info = gl_strings(self.backend)
        return dict(self._gl_info)

    def observe(self, *, render: bool = True) -> dict[str, Any]:
        raw = self._env._get_observations()
        eef_quat = np.asarray(raw["robot0_eef_quat"], dtype=np.float64)
        gripper = np.asarray(raw["robot0_gripper_qpos"], dtype=np.float64)
        obs: dict[str, Any] = {
            "state": np.concatenate([raw["robot0_eef_pos"], quat_to_axis_angle(eef_quat), gripper]).astype(
                np.float32
            ),
            "joint_pos": np.asarray(raw["robot0_joint_pos"], dtype=np.float32),
            "gripper_state": gripper.astype(np.float32),
            "eef_pos": np.asarray(raw["robot0_eef_pos"], dtype=np.float32),
            "eef_quat": eef_quat.astype(np.float32),
            "object_poses": self.object_poses(),
            "sim_state": self.get_state(),
        }
        if render:
            for camera in self.config.cameras:
                obs[camera] = self.render(camera)
        if self.perturbation is not None:
            from libero_data.perturb.apply import observe

            observe(obs, self.perturbation, self.config.cameras if render else ())
        return obs

    def object_poses(self) -> dict[str, np.ndarray]:
        """World pose ``[x, y, z, qx, qy, qz, qw]`` of every object and fixture root body."""
        data = self._env.sim.data
        poses = {}
        for name, body_id in self._env.obj_body_id.items():
            poses[name] = np.concatenate([data.xpos[body_id], wxyz_to_xyzw(data.xquat[body_id])])
        return poses

    # success ----------------------------------------------------------------------------
    def success(self) -> bool:
        """Whether the task's goal formula holds in the current state."""
        return self.holds(self.problem.goal)

    def holds(self, formula: Formula) -> bool:
        """Evaluate a goal formula with LIBERO's predicate functions."""
        if isinstance(formula, Atom):
            from libero.libero.envs.predicates import eval_predicate_fn

            states = self._env.object_states_dict
            return bool(eval_predicate_fn(formula.predicate.lower(), *[states[a] for a in formula.args]))
        if isinstance(formula, Not):
            return not self.holds(formula.term)
        if isinstance(formula, And):
            return all(self.holds(t) for t in formula.terms)
        assert isinstance(formula, Or)
        return any(self.holds(t) for t in formula.terms)

    # lifetime ---------------------------------------------------------------------------
    def close(self) -> None:
        fast = self.__dict__.pop("fast_images", None)
        if fast is not None:
            fast.close()
        if getattr(self, "_closed", True) is False or hasattr(self, "_env"):
            env = self.__dict__.pop("_env", None)
            if env is not None:
                env.close()
        self._closed = True

    def __enter__(self) -> LiberoEnv:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def _zero_reward(action: Any = None) -> float:
    return 0.0


def _perturbation_of(text: str) -> Any:
    """The task's robustness perturbation (libero_data.perturb), or None."""
    if not text:
        return None
    from libero_data.perturb.spec import Perturbation

    return Perturbation.from_json(text)


def _resolve(task: Task | str | Path) -> tuple[Path, Task | None]:
    from libero_data.tasks import Task, get_task

    if isinstance(task, Task):
        return task.bddl_path, task
    path = Path(task)
    if path.suffix == ".bddl":
        if not path.is_file():
            raise MissingFileError(f"BDDL file {path} does not exist")
        return path, None
    resolved = get_task(str(task))
    return resolved.bddl_path, resolved
