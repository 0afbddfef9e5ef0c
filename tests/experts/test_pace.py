"""What issue 74 changed in how the expert works: drawers opened just past LIBERO's threshold, what
an opening drawer leaves graspable, a bowl pushed aside only as far as needed, the rise and travel
of a carried object at once, and the faster close-in of a move. Geometry and small stand-ins; the
episodes themselves are counted in tests/experts/test_skills.py and the committed tables."""

from __future__ import annotations

from types import SimpleNamespace
from typing import cast

import numpy as np
import pytest

from libero_data.experts.motion import FINAL_GAIN, Motion, Style
from libero_data.experts.skills.base import Context
from libero_data.experts.skills.carry import _diagonal_start

DRAWER = "wooden_cabinet_1_top_region"
BOWL = "akita_black_bowl_1"


@pytest.fixture(scope="module")
def goal_3():
    """libero_goal/3 from stored init state 8: its bowl stands so far where the top drawer opens
    that no grasp as deep as now is left once it is open (cards/expert_report: pushed aside)."""
    from libero_data.experts import Expert
    from libero_data.sim import EnvConfig, LiberoEnv
    from libero_data.tasks import get_task

    task = get_task("libero_goal/3")
    with LiberoEnv(task, EnvConfig(cameras=())) as env:
        env.reset(task.init_states()[8], seed=0, settle=20, render=False)
        yield Expert(env)


@pytest.mark.sim
def test_a_drawer_opens_just_past_liberos_threshold(goal_3) -> None:
    from libero_data.experts.skills.articulation import part_in
    from libero_data.experts.skills.drawer import OPEN_MARGIN, open_target

    part = part_in(goal_3.scene, DRAWER)
    # The wooden cabinet's drawer is open (LIBERO) below qpos -0.14 of its range (-0.16, 0.01):
    # 0.15 out of the closed position, 0.17 of travel.
    assert open_target(goal_3.scene, part) == pytest.approx(0.15 + OPEN_MARGIN)
    assert open_target(goal_3.scene, part) < abs(part.joint.range[1] - part.joint.range[0])


@pytest.mark.sim
def test_what_the_open_drawer_leaves_graspable_depends_on_where_the_bowl_stands(goal_3) -> None:
    from libero_data.experts.skills.drawer import covered_by_opening, grasp_left_open

    scene = goal_3.scene
    assert covered_by_opening(scene, DRAWER, BOWL)  # the bowl stands partly where the drawer opens
    assert not grasp_left_open(scene, DRAWER, BOWL)
    # 12 cm toward the robot it is clear of the drawer; 6 cm further under it, still nothing.
    assert grasp_left_open(scene, DRAWER, BOWL, shift=np.array([-0.12, 0.0]))
    assert not grasp_left_open(scene, DRAWER, BOWL, shift=np.array([0.06, 0.0]))


@pytest.mark.sim
def test_a_bowl_is_pushed_aside_the_shortest_way_it_leaves_a_deep_grasp(goal_3) -> None:
    from libero_data.experts.skills.base import Context
    from libero_data.experts.skills.drawer import grasp_left_open
    from libero_data.experts.skills.push_aside import LONGEST, _ways_out

    rng = np.random.default_rng(0)
    ctx = Context(
        scene=goal_3.scene, motion=Motion(goal_3.scene, Style(), rng), rng=rng, problem=goal_3.env.problem
    )
    ways = _ways_out(ctx, BOWL, DRAWER)
    assert ways, "some way out of the drawer's sweep"
    assert [d for _, d in ways] == sorted(d for _, d in ways)
    for direction, distance in ways:
        assert 0 < distance <= LONGEST
        assert grasp_left_open(goal_3.scene, DRAWER, BOWL, shift=direction * distance)


class _Scene:
    """Obstacle points only (what ``_diagonal_start`` reads)."""

    def __init__(self, points: np.ndarray) -> None:
        self.points = points

    def obstacle_points(self, exclude: tuple[str, ...] = ()) -> np.ndarray:
        return self.points


def _ctx(points: np.ndarray) -> Context:
    # Only the two attributes _diagonal_start reads.
    return cast(Context, SimpleNamespace(scene=_Scene(points), held="cup"))


def test_a_carried_object_rises_only_as_high_as_the_way_needs() -> None:
    start, end = np.array([0.0, 0.0, 1.0]), np.array([0.4, 0.0])
    travel = 1.2
    # Nothing on the way: it travels up and over from where it is.
    clear = _ctx(np.array([[0.0, 0.5, 0.9]]))
    assert _diagonal_start(clear, start, end, travel, 0.05, 0.05, ()) == pytest.approx(1.0)
    # A box 1.1 m high right beside the start: it rises (nearly) to the travel height first.
    box = _ctx(np.array([[0.05, 0.0, 1.1]]))
    assert _diagonal_start(box, start, end, travel, 0.05, 0.05, ()) >= 1.15
    # A lower box near the end: the straight line up from where it is clears it.
    far = _ctx(np.array([[0.36, 0.0, 1.05]]))
    assert _diagonal_start(far, start, end, travel, 0.05, 0.05, ()) == pytest.approx(1.0)


class _Arm:
    """A stand-in whose grip site covers a quarter of each step's command (the OSC's pace)."""

    def __init__(self) -> None:
        self.pos = np.zeros(3)

    def eef_pos(self) -> np.ndarray:
        return self.pos.copy()

    def eef_mat(self) -> np.ndarray:
        return np.eye(3)


def _steps_to(gain: float) -> int:
    arm = _Arm()
    motion = Motion(arm, Style(noise=0.0), np.random.default_rng(0))  # type: ignore[arg-type]
    steps = 0
    for action in motion.move(np.array([0.02, 0.0, 0.0]), tol=0.002, gain=gain, max_steps=100):
        arm.pos += 0.25 * action[:3] * 0.05
        steps += 1
    return steps


def test_a_move_closes_in_faster_at_its_gain() -> None:
    assert FINAL_GAIN > 1.0
    assert _steps_to(FINAL_GAIN) < _steps_to(1.0)


class _Reach:
    """A shoulder at the origin and an elbow at ``slack`` rad from its folded stop."""

    def __init__(self, slack: float) -> None:
        self.slack = slack

    def shoulder_pos(self) -> np.ndarray:
        return np.zeros(3)

    def joint(self, name: str) -> SimpleNamespace:
        assert name == "robot0_joint4"
        return SimpleNamespace(qpos=-3.0718 + self.slack, range=(-3.0718, -0.0698))


def test_a_grasp_leans_back_where_the_elbow_nears_its_stop() -> None:
    from libero_data.experts.geometry import top_down
    from libero_data.experts.grasp import Grasp
    from libero_data.experts.skills.pick import ELBOW_ROOM, TOO_CLOSE, _elbow_at_stop, _leaning_back

    # A can 0.31 m in front of the shoulder: beyond TOO_CLOSE, fingers closing sideways.
    grasp = Grasp(
        pos=np.array([0.31, 0.0, -0.2]), mat=top_down(np.pi / 2), yaw=np.pi / 2, width=0.06, score=5.0
    )
    assert TOO_CLOSE < 0.31
    roomy, folded = (cast(Context, SimpleNamespace(scene=_Reach(s))) for s in (ELBOW_ROOM + 0.01, 0.08))
    assert not _elbow_at_stop(roomy) and _elbow_at_stop(folded)
    # Far enough by distance alone: unchanged unless the elbow says so.
    assert _leaning_back(roomy, grasp) is grasp
    leaned = _leaning_back(folded, grasp, close=True)
    approach = leaned.mat[:, 2]
    # Tilted by LEAN_BACK toward the robot (-x), the fingers still closing along y.
    assert np.degrees(np.arccos(-approach[2])) == pytest.approx(25.0)
    assert approach[0] < 0 and abs(approach[1]) < 1e-9
    assert np.allclose(leaned.mat[:, 0], grasp.mat[:, 0])
    # Once tilted, it is not tilted again; fingers closing toward the robot are never tilted.
    assert _leaning_back(folded, leaned, close=True) is leaned
    along = Grasp(pos=grasp.pos, mat=top_down(0.0), yaw=0.0, width=0.06, score=5.0)
    assert _leaning_back(folded, along, close=True) is along
