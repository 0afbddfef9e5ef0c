"""The scripted expert: plan a task's goal into skills and run them in the simulator.

>>> expert = Expert(env)
>>> episode = expert.run(init_state, reset_seed=0, seed=7)
>>> episode.success, episode.actions.shape, episode.states.shape

Episodes are searched without cameras. What is kept is exactly what is needed to re-create
and re-render the episode: the reset seed (fixture placement), the canonical first state
and the actions, stored as float32 and executed as float32, so replaying them gives the
same states bit for bit.
"""

from __future__ import annotations

import logging
from collections import Counter
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from libero_data.config import Config
from libero_data.experts.motion import Motion, Style
from libero_data.experts.planner import Step, plan
from libero_data.experts.scene import SceneView
from libero_data.experts.skills import SKILLS, Context, SkillFailed

if TYPE_CHECKING:
    from libero_data.sim import LiberoEnv

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class ExpertConfig(Config):
    """Limits and the ranges that per-episode styles are drawn from."""

    max_steps: int = 1000  # two-object libero_10 tasks take up to ~700 steps
    settle_steps: int = 20
    retries: int = 1  # extra attempts of a failed pick-and-place or articulation
    # Free-space speed (m/s of the set-point) and the factor on turns and fine motions
    # (Style.tempo), drawn per episode. (0.28, 0.42) and 1.0 until the demonstrations were
    # measured against LIBERO's human ones (benchmarks/RESULTS.md, "Expert: where the steps go");
    # (0.32, 0.46) until issue 74. Faster fine motions (tempo 1.6-1.9) took a further 8% off but
    # missed more grasps (3 inits of every task), so only free-space motion got faster.
    speed: tuple[float, float] = (0.38, 0.46)
    noise: tuple[float, float] = (0.0, 0.03)
    tempo: tuple[float, float] = (1.3, 1.5)
    tail_steps: int = 25  # steps to wait for success after the plan (objects settling)

    def __post_init__(self) -> None:
        if self.max_steps <= 0:
            raise ValueError(f"max_steps must be positive, got {self.max_steps}")
        if self.settle_steps < 0 or self.retries < 0 or self.tail_steps < 0:
            raise ValueError("settle_steps, retries and tail_steps must not be negative")
        for name in ("speed", "noise", "tempo"):
            lo, hi = getattr(self, name)
            if not 0 <= lo <= hi:
                raise ValueError(f"{name} must be a range (lo, hi) with 0 <= lo <= hi, got {(lo, hi)}")


@dataclass
class Episode:
    """One expert attempt. ``states[t]`` is the state in which ``actions[t]`` was taken."""

    success: bool
    actions: np.ndarray  # (T, 7) float32
    states: np.ndarray  # (T, D) float64
    final_state: np.ndarray  # (D,) after the last action
    reset_seed: int
    seed: int
    plan: list[str] = field(default_factory=list)
    failure: str | None = None
    setbacks: list[str] = field(default_factory=list)  # every skill failure, retried or not
    #: Where the steps went: per skill of the plan and, where the skill says, its phase
    #: (``pick: approach``, ``pick: descend``, ``pick: grasp``, ``pick: lift``, ``pick: regrasp``,
    #: ``place_on: transport``, ``place_on: lower``, ``place_on: release``, ...), ``failed attempts``
    #: (steps of a pick-and-place or articulation that failed, retried or not) and ``wait for
    #: goal`` (the tail after the plan); the counts add up to the episode's length.
    phases: dict[str, int] = field(default_factory=dict)

    @property
    def length(self) -> int:
        return int(self.actions.shape[0])


class _Budget(Exception):
    pass


class _Done(Exception):
    pass


class Expert:
    """Runs the goal-driven skill plan of ``env``'s task."""

    def __init__(self, env: LiberoEnv, config: ExpertConfig | None = None) -> None:
        self.env = env
        self.config = config or ExpertConfig()
        self.scene = SceneView(env)

    def style(self, rng: np.random.Generator) -> Style:
        c = self.config
        speed, noise = float(rng.uniform(*c.speed)), float(rng.uniform(*c.noise))
        return Style(speed=speed, noise=noise, tempo=float(rng.uniform(*c.tempo)))

    def plan(self) -> list[Step]:
        scene = self.scene
        problem = self.env.problem

        def joint_kind(name: str) -> str | None:
            joints = _region_joints(self.env, name)
            return scene.joint(joints[0]).kind if joints else None

        def is_open(region: str) -> bool:
            return not _region_joints(self.env, region) or bool(
                self.env.raw.object_states_dict[region].is_open()
            )

        def graspable(obj: str) -> bool:
            from libero_data.experts.grasp import has_top_down_grasp

            lo, hi = scene.aabb(obj)
            if hi[2] - lo[2] < 0.03 and max(hi[:2] - lo[:2]) > 0.12:
                return False  # flat and wide (a plate): slide it instead
            return has_top_down_grasp(scene, obj)

        def covered(drawer: str, obj: str) -> bool:
            from libero_data.experts.skills.drawer import covered_by_opening, grasp_left_open

            return (
                not is_open(drawer)
                and covered_by_opening(scene, drawer, obj)
                and not grasp_left_open(scene, drawer, obj)
            )

        return plan(problem, joint_kind=joint_kind, is_open=is_open, graspable=graspable, covered=covered)

    def run(self, init_state: np.ndarray | None, *, reset_seed: int = 0, seed: int = 0) -> Episode:
        """One episode from ``init_state`` (fixtures placed from ``reset_seed``), styled by ``seed``."""
        env, cfg = self.env, self.config
        env.reset(init_state, seed=reset_seed, settle=cfg.settle_steps, render=False)
        rng = np.random.default_rng(seed)
        ctx = Context(
            scene=self.scene, motion=Motion(self.scene, self.style(rng), rng), rng=rng, problem=env.problem
        )
        steps = self.plan()
        states: list[np.ndarray] = []
        actions: list[np.ndarray] = []
        phases: Counter[str] = Counter()
        attempt_steps: Counter[str] = Counter()  # the attempt in progress, by skill

        def execute(step: Step) -> None:
            ctx.phase = None
            gen = SKILLS.get(step.skill)(*step.args).run(ctx)
            for action in gen:
                a = np.asarray(action, dtype=np.float32)
                states.append(env.get_state())
                actions.append(a)
                attempt_steps[f"{step.skill}: {ctx.phase}" if ctx.phase else step.skill] += 1
                if env.advance(a):
                    raise _Done
                if len(actions) >= cfg.max_steps:
                    raise _Budget

        failure: str | None = None
        setbacks: list[str] = []
        success = False
        try:
            for unit in _units(steps):
                if all(s.atom is not None and env.holds(s.atom) for s in unit if s.atom is not None) and any(
                    s.atom is not None for s in unit
                ):
                    continue
                for attempt in range(cfg.retries + 1):
                    try:
                        for step in unit:
                            execute(step)
                        phases.update(attempt_steps)
                        attempt_steps.clear()
                        break
                    except SkillFailed as exc:
                        failure = str(exc)
                        setbacks.append(f"{unit[-1]}: {exc}")
                        log.debug("attempt %d of %s failed: %s", attempt, unit, exc)
                        ctx.held = None
                        phases["failed attempts"] += sum(attempt_steps.values())
                        attempt_steps.clear()
                else:
                    raise _Budget
            failure = "goal not reached after the plan"
            # Objects may still be settling (a drop into a basket): wait a little for the goal.
            for action in ctx.motion.hold(cfg.tail_steps):
                a = np.asarray(action, dtype=np.float32)
                states.append(env.get_state())
                actions.append(a)
                phases["wait for goal"] += 1
                if env.advance(a):
                    raise _Done
        except _Done:
            success, failure = True, None
        except _Budget:
            failure = failure or f"step budget of {cfg.max_steps} exhausted"
        phases.update(attempt_steps)  # the attempt the goal or the budget ended
        return Episode(
            success=success,
            actions=np.asarray(actions, dtype=np.float32).reshape(-1, 7),
            states=np.asarray(states, dtype=np.float64).reshape(len(states), env.state_dim),
            final_state=env.get_state(),
            reset_seed=reset_seed,
            seed=seed,
            plan=[str(s) for s in steps],
            failure=failure,
            setbacks=setbacks,
            phases=dict(phases),
        )


def _units(steps: list[Step]) -> list[list[Step]]:
    """Group a pick with the place that follows it, so a failed place retries the pick."""
    units: list[list[Step]] = []
    for step in steps:
        if units and units[-1][-1].skill == "pick":
            units[-1].append(step)
        else:
            units.append([step])
    return units


def _region_joints(env: LiberoEnv, name: str) -> list[str]:
    states = env.raw.object_states_dict
    if name not in states:
        return []
    state = states[name]
    if hasattr(state, "parent_name"):  # a site: its own joints (drawers)
        site = env.raw.object_sites_dict.get(name)
        return list(getattr(site, "joints", None) or [])
    obj = env.raw.get_object(name)
    model = env.sim.model
    hinged = []
    for joint in getattr(obj, "joints", None) or []:
        if joint in model.joint_names and int(model.jnt_type[model.joint_name2id(joint)]) in (2, 3):
            hinged.append(joint)  # slide or hinge: a drawer, door or knob (not a free joint)
    return hinged
