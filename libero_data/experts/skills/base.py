"""What every skill shares: the registry, the context it runs in, and common motions."""

from __future__ import annotations

from collections.abc import Generator
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np

from libero_data.bddl import Problem
from libero_data.experts.geometry import rotation_error, top_down, yaw_of_closing
from libero_data.experts.motion import Actions, Motion
from libero_data.experts.scene import SceneView
from libero_data.registry import Registry


class SkillFailed(RuntimeError):
    """A skill could not do its job in this episode (the episode is discarded or retried)."""


@dataclass
class Context:
    """Everything a skill may use: the scene, the motion generator, randomness, the task."""

    scene: SceneView
    motion: Motion
    rng: np.random.Generator
    problem: Problem
    held: str | None = None  # the object in the gripper, if any
    notes: dict[str, Any] = field(default_factory=dict)
    #: What the skill is doing now (``approach``, ``grasp``, ``transport``, ...), for counting
    #: where an episode's steps go; a label only, it changes no action.
    phase: str | None = None

    # small shared helpers -------------------------------------------------------------------
    def jitter(self, scale: float, size: int | None = None) -> Any:
        return self.rng.uniform(-scale, scale, size)

    def category(self, name: str) -> str:
        try:
            return self.problem.category_of(name)
        except KeyError:
            return ""

    def parent_of(self, region: str) -> str:
        """The object or fixture a region belongs to (``wooden_cabinet_1_top_region`` -> ``wooden_cabinet_1``)."""
        for r in self.problem.regions:
            if r.full_name == region:
                return r.target
        for e in self.problem.entities:
            if region.startswith(e.name + "_"):
                return e.name
        return region

    def is_entity(self, name: str) -> bool:
        return any(e.name == name for e in self.problem.entities)

    def current_top_down(self) -> np.ndarray:
        return top_down(yaw_of_closing(self.scene.eef_mat()))

    def table_height(self) -> float:
        """Height of the surface the scene stands on."""
        return float(self.notes.setdefault("table_height", _table_height(self)))

    def clear_height(
        self, xy_from: np.ndarray, xy_to: np.ndarray, exclude: tuple[str, ...], radius: float
    ) -> float:
        """Highest obstacle point within ``radius`` of the segment between two table points."""
        pts = self.scene.obstacle_points(exclude=exclude)
        a, b = np.asarray(xy_from[:2]), np.asarray(xy_to[:2])
        ab = b - a
        t = np.clip(((pts[:, :2] - a) @ ab) / max(float(ab @ ab), 1e-9), 0.0, 1.0)
        closest = a + t[:, None] * ab
        near = np.linalg.norm(pts[:, :2] - closest, axis=1) < radius
        return float(pts[near, 2].max()) if near.any() else self.table_height()


def _table_height(ctx: Context) -> float:
    """The surface everything stands on: the lowest resting point of any movable object."""
    bottoms = [float(ctx.scene.points(o.name)[:, 2].min()) for o in ctx.problem.objects]
    return min(bottoms) if bottoms else 0.0


class Skill:
    """One reusable behaviour: a generator of actions, closed loop on privileged state.

    Subclasses set ``name`` and implement :meth:`run`; ``args`` are BDDL names.
    """

    name: ClassVar[str] = ""

    def __init__(self, *args: str) -> None:
        self.args = args

    def run(self, ctx: Context) -> Actions:  # pragma: no cover - abstract
        raise NotImplementedError

    def __repr__(self) -> str:
        return f"{self.name}({', '.join(self.args)})"


SKILLS: Registry[type[Skill]] = Registry("skill")


def lift(ctx: Context, height: float, mat: np.ndarray | None = None, speed: float | None = None) -> Actions:
    """Move straight up to ``height`` (grip-site z)."""
    pos = ctx.scene.eef_pos()
    pos[2] = max(pos[2], height)
    return (yield from ctx.motion.move(pos, mat, speed=speed, tol=0.015, max_steps=60))


def go_to_pose(
    ctx: Context, pos: np.ndarray, mat: np.ndarray, clearance: float = 0.08, stall: int | None = None
) -> Actions:
    """Reach a pose near obstacles: rise, travel above it, turn the wrist in free air, descend.

    ``stall``: give up the turn and the descent once that many steps gain nothing (a pose the
    arm cannot take here); False then.
    """
    here = ctx.scene.eef_pos()
    high = max(here[2], pos[2] + clearance)
    if here[2] < high - 0.01:
        yield from ctx.motion.move(np.array([here[0], here[1], high]), None, tol=0.015, max_steps=60)
    yield from ctx.motion.move(np.array([pos[0], pos[1], high]), None, tol=0.015, max_steps=150)
    yield from ctx.motion.move(
        np.array([pos[0], pos[1], high]), mat, tol=0.02, rot_tol=0.08, max_steps=60, stall=stall
    )
    return (yield from ctx.motion.move(pos, mat, tol=0.01, max_steps=80, stall=stall))


def turn_wrist(ctx: Context, angle: float, limit: float = 2.75) -> Generator[np.ndarray, None, float]:
    """Turn the held object about the vertical by ``angle`` (mod 2 pi), within the wrist's range.

    Of the equivalent turns, the one that keeps the last arm joint inside +-``limit`` rad is
    taken, in steps of at most 0.6 rad so the arm turns the intended way. Returns the turn.
    """
    from libero_data.experts.geometry import rot_z

    q7 = ctx.scene.joint("robot0_joint7").qpos
    angle = (angle + np.pi) % (2 * np.pi) - np.pi
    options = [angle, angle - 2 * np.pi, angle + 2 * np.pi]
    # A positive turn about world z turns the top-down hand's last joint the other way.
    feasible = [a for a in options if abs(q7 - a) <= limit] or [min(options, key=lambda a: abs(q7 - a))]
    chosen = min(feasible, key=abs)
    start = ctx.scene.eef_mat()
    pos = ctx.scene.eef_pos()
    steps = max(1, int(np.ceil(abs(chosen) / 0.6)))
    for i in range(1, steps + 1):
        yield from ctx.motion.move(
            pos, rot_z(chosen * i / steps) @ start, tol=0.02, rot_tol=0.12, max_steps=25
        )
    return chosen


def upright(ctx: Context, height: float | None = None, within: float = 25.0) -> Actions:
    """Back to a top-down hand (after a drawer, door or side insertion), turned in free air.

    The arm struggles to swing from a horizontal hand into a top-down one while reaching
    for something else at the same time; this does the turn first, above the scene. A hand
    already within ``within`` degrees of pointing down is left to turn on its way.
    """
    mat = ctx.scene.eef_mat()
    if float(mat[:, 2] @ np.array([0.0, 0.0, -1.0])) > np.cos(np.deg2rad(within)):
        return True
    here = ctx.scene.eef_pos()
    z = max(here[2], height if height is not None else here[2] + 0.08)
    target = ctx.current_top_down()
    yield from ctx.motion.move(np.array([here[0], here[1], z]), None, tol=0.015, max_steps=40)
    return (
        yield from ctx.motion.move(
            np.array([here[0], here[1], z]), target, tol=0.02, rot_tol=0.1, max_steps=60
        )
    )


def wait_until_still(ctx: Context, name: str, max_steps: int = 20, speed: float = 0.01) -> Actions:
    """Hold still until ``name`` has come to rest (after a drop or a failed grasp)."""
    ctx.phase = "wait"
    for _ in range(max_steps):
        if ctx.scene.speed(name) < speed:
            return True
        yield from ctx.motion.hold(1)
    return False


def settle_orientation(ctx: Context, mat: np.ndarray, steps: int = 30) -> Actions:
    """Turn the wrist in place until it matches ``mat``."""
    pos = ctx.scene.eef_pos()
    for _ in range(steps):
        if np.linalg.norm(rotation_error(mat, ctx.scene.eef_mat())) < 0.05:
            return True
        yield from ctx.motion.move(pos, mat, max_steps=1)
    return False


def run_all(*gens: Generator[np.ndarray, None, Any]) -> Actions:
    ok = True
    for gen in gens:
        ok = bool((yield from gen)) and ok
    return ok
