"""The expert's skills on a handful of tasks, as rates over several starts; and determinism.

An episode's outcome is not asserted: on a machine whose numeric path differs
(docs/reproducibility.md) the same start can end otherwise. Each task is instead run from several
stored init states, and the number of successes must reach a margin derived from the committed
expert table (``cards/expert_report.csv``): with the lower end of the 95% interval of the task's
measured rate, the fewest starts for which "no success" is a 0.1% event, and at least the 0.1%
quantile of successes over them. A working expert fails a task's check with probability <= 0.1%.
"""

from __future__ import annotations

import csv
import functools
from pathlib import Path

import numpy as np
import pytest

from libero_data.experts import Expert
from libero_data.experts.skills import SKILLS
from libero_data.seeding import episode_seeds
from libero_data.sim import EnvConfig, LiberoEnv
from libero_data.stats import least_successes, starts_needed, wilson_interval
from libero_data.tasks import get_task

pytestmark = pytest.mark.sim

TABLE = Path(__file__).resolve().parents[2] / "cards" / "expert_report.csv"
#: The chance, per task, that a working expert fails its check.
ALPHA = 0.001
#: Styles and fixture placements the table did not use (it used seed 0).
SEED = 11
#: The most starts a task's check may take.
MOST_STARTS = 12

CASES = {
    "libero_object/0": ["pick", "place_in"],  # into a basket
    "libero_spatial/0": ["pick", "place_on"],  # a bowl onto a plate
    "libero_spatial/9": ["pick", "place_on"],  # off a cabinet onto a far plate: held on its near rim
    "libero_goal/0": ["open_drawer"],  # a middle drawer: grasped
    "libero_90/6": ["open_drawer"],  # a bottom drawer 4.6 cm above the table: hooked
    "libero_goal/5": ["push"],  # a plate, its back to a cabinet: dragged from inside its rim
    "libero_goal/7": ["turn_on"],
    "libero_90/33": ["close_door"],
    "libero_90/73": ["pick", "place_in"],  # a book upright into a narrow caddy slot
    "libero_90/42": ["pick", "place_in"],  # a pan by its handle, sideways under a shelf
    "libero_90/40": ["pick", "place_in"],  # a wide pan slid in between a shelf's side walls
    "libero_90/86": ["pick", "place_in"],  # a book too tall for a shelf layer: slid in on edge
    "libero_90/89": ["pick", "place_in"],  # a book under a 7-cm layer: laid flat, dragged in
    "libero_90/32": ["pick", "place_in"],  # a tall bottle laid down in a shallow drawer
    "libero_90/13": ["pick", "place_on"],  # a bowl at the far edge of the arm's reach
    "libero_90/36": ["pick", "place_on"],  # a 2 g thin-walled bowl: pre-shaped hand pinches its wall
    "libero_90/62": ["pick", "place_in"],  # a bottle close to the robot: the hand leans back
    # the bowl stands where the drawer opens, but keeps a grasp as deep as now beside the open
    # drawer: opened first, nothing set aside (at other starts it is pushed aside first)
    "libero_90/8": ["open_drawer", "pick", "place_in"],
    "libero_goal/3": ["open_drawer", "pick", "place_in"],
}


def test_every_skill_is_registered() -> None:
    assert set(SKILLS.names()) >= {
        "pick",
        "place_on",
        "place_in",
        "open_drawer",
        "close_drawer",
        "open_door",
        "close_door",
        "turn_on",
        "turn_off",
        "push",
        "push_aside",
        "set_aside",
    }


@functools.cache
def _table() -> dict[str, tuple[int, int]]:
    with TABLE.open(newline="") as f:
        return {
            f"{r['suite']}/{r['index']}": (int(r["successes"]), int(r["episodes"])) for r in csv.DictReader(f)
        }


def margin(ref: str) -> tuple[int, int, str]:
    """(starts, least successes, the table's evidence in words) for a task's check."""
    successes, episodes = _table()[ref]
    low = wilson_interval(successes, episodes)[0]
    starts = starts_needed(low, ALPHA, most=MOST_STARTS)
    need = least_successes(starts, low, ALPHA)
    return starts, need, f"{successes}/{episodes} in the committed table (95% interval from {low:.0%})"


def test_margins_come_from_the_table() -> None:
    assert set(CASES) <= set(_table())
    for ref in CASES:
        starts, need, evidence = margin(ref)
        assert need >= 1, f"{ref}: {evidence} is too low to check in {starts} starts"


@pytest.mark.parametrize("ref", sorted(CASES))
def test_skills_solve_tasks(ref: str) -> None:
    starts, need, evidence = margin(ref)
    task = get_task(ref)
    inits = task.init_states()
    solved, failures = 0, []
    with LiberoEnv(task, EnvConfig(cameras=())) as env:
        expert = Expert(env)
        for i in range(1, starts + 1):
            reset_seed, seed = episode_seeds(SEED, task.id, i)
            episode = expert.run(inits[i], reset_seed=reset_seed, seed=seed)
            if i == 1:  # the plan these cases are about (other starts may need another)
                assert [p.split("(")[0] for p in episode.plan] == CASES[ref]
            assert episode.actions.dtype == np.float32 and episode.actions.shape == (episode.length, 7)
            assert np.all(np.abs(episode.actions) <= 1.0)
            if episode.success:
                solved += 1
            else:
                failures.append(f"init {i}: {episode.failure}")
            if i == 1:
                # The stored first state and the actions replay to the same end, bit for bit.
                env.reset(seed=reset_seed, render=False)
                env.set_state(episode.states[0])
                for action in episode.actions:
                    env.step(action, render=False)
                np.testing.assert_array_equal(env.get_state(), episode.final_state)
                assert env.success() == episode.success
    assert solved >= need, (
        f"{ref}: the expert solved {solved} of {starts} starts (inits 1..{starts}, seed {SEED}); with "
        f"{evidence}, fewer than {need} has probability <= {ALPHA:.1%}. Failures: {'; '.join(failures)}"
    )


def test_same_seed_same_episode_other_seed_other_episode() -> None:
    task = get_task("libero_object/1")
    with LiberoEnv(task, EnvConfig(cameras=())) as env:
        expert = Expert(env)
        a = expert.run(task.init_states()[0], reset_seed=0, seed=5)
        b = expert.run(task.init_states()[0], reset_seed=0, seed=5)
        c = expert.run(task.init_states()[0], reset_seed=0, seed=6)
    assert a.success == b.success and a.length > 50
    np.testing.assert_array_equal(a.actions, b.actions)
    np.testing.assert_array_equal(a.states, b.states)
    assert a.actions.shape != c.actions.shape or not np.array_equal(a.actions, c.actions)


def test_drawer_strategy_follows_the_room_around_the_handle() -> None:
    """Grasp where the hand fits; hook a handle with the table close below or nothing above."""
    from libero_data.experts.motion import Motion
    from libero_data.experts.skills.articulation import part_in
    from libero_data.experts.skills.base import Context
    from libero_data.experts.skills.drawer import _clear_above, _grasp_pitches, _handle

    seen = {}
    for ref, region in [
        ("libero_90/6", "wooden_cabinet_1_bottom_region"),
        ("libero_goal/0", "wooden_cabinet_1_middle_region"),
        ("libero_90/7", "wooden_cabinet_1_top_region"),
    ]:
        task = get_task(ref)
        with LiberoEnv(task, EnvConfig(cameras=())) as env:
            expert = Expert(env)
            env.reset(task.init_states()[0], seed=0, settle=20, render=False)
            rng = np.random.default_rng(0)
            motion = Motion(expert.scene, expert.style(rng), rng)
            ctx = Context(scene=expert.scene, motion=motion, rng=rng, problem=env.problem)
            part = part_in(expert.scene, region)
            centre, out, bar = _handle(ctx, part)
            seen[ref] = (
                _grasp_pitches(ctx, part, centre, out, bar),
                _clear_above(ctx, part, centre, out, bar),
            )
    assert seen["libero_90/6"] == ([], False)  # the hand meets the table or the bar above: hook
    assert seen["libero_goal/0"] == ([0.0], False)  # level grasp fits (the plate nearby moves)
    assert seen["libero_90/7"][1] is True  # a top drawer: hooked from above
