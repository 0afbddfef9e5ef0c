"""The expert's pace: every suite's demonstrations are held to the bound on their 95th
percentile length (``libero_data.cards.expert_table.LENGTH_BOUNDS``).

The committed measurement of today's expert (``cards/expert_report.jsonl``: 50 stored init states
of every task of the five suites, the table the dataset cards are made from) must be within the
bounds. And on a small sample: one episode's length is
not asserted (on another numeric path the same start can take other steps); per suite, a few
successful episodes from starts and styles the measurement did not use are counted against
the bound; how many may exceed it comes from the measurement: at the upper end of the 95%
interval of the share of its episodes over the bound, more than that many over it has
probability <= 0.1%. An expert that got slower (half its pace, a wait added to every grasp)
fails; one as fast as measured fails with probability <= 0.1% per suite.
"""

from __future__ import annotations

import functools
import json
from pathlib import Path

import pytest

from libero_data.cards.expert_table import LENGTH_BOUNDS
from libero_data.experts import Expert
from libero_data.seeding import episode_seeds
from libero_data.sim import EnvConfig, LiberoEnv
from libero_data.stats import binomial_cdf, wilson_interval
from libero_data.tasks import get_task

pytestmark = pytest.mark.sim

REPORT = Path(__file__).resolve().parents[2] / "cards" / "expert_report.jsonl"
ALPHA = 0.001
SEED = 11  # styles and placements the table (seed 0) did not use
#: Per suite, two tasks (drawn once with numpy.random.default_rng(35), then fixed) and three
#: starts each.
SAMPLE = {
    "libero_spatial": (0, 3),
    "libero_object": (4, 9),
    "libero_goal": (2, 9),
    "libero_10": (0, 5),
    "libero_90": (30, 40),
}
STARTS = (1, 2, 3)


@functools.cache
def _report() -> tuple[dict[str, object], list[dict[str, object]]]:
    lines = REPORT.read_text().splitlines()
    return json.loads(lines[0])["settings"], [json.loads(line) for line in lines[1:]]


def _lengths(suite: str) -> list[int]:
    """Every successful episode's length of the suite in the committed measurement."""
    return [int(n) for r in _report()[1] if r["suite"] == suite for n in r["lengths"]]  # type: ignore[attr-defined]


def _over_share(suite: str) -> tuple[int, int]:
    """(episodes over the bound, successful episodes) of the suite in the committed measurement."""
    lengths = _lengths(suite)
    return sum(n > LENGTH_BOUNDS[suite] for n in lengths), len(lengths)


def test_the_measurement_is_of_todays_expert_on_every_task() -> None:
    # Any change to the code that decides an episode (libero_data.provenance.EPISODE_CODE)
    # needs it measured again: `libero-data expert-report --workers 2 --out cards` (cards/README.md).
    from libero_data.provenance import expert_code
    from libero_data.tasks import SUITE_NAMES, get_suite

    settings, rows = _report()
    assert settings["expert"] == expert_code(), "the expert changed since it was measured"
    assert sorted(str(r["ref"]) for r in rows) == sorted(
        f"{name}/{t.index}" for name in SUITE_NAMES[:5] for t in get_suite(name).tasks
    )
    for r in rows:
        assert len(r["lengths"]) == r["successes"], r["ref"]  # type: ignore[arg-type]


@pytest.mark.parametrize("suite", sorted(LENGTH_BOUNDS))
def test_each_suites_95th_percentile_is_within_its_bound(suite: str) -> None:
    import numpy as np

    assert float(np.percentile(_lengths(suite), 95)) <= LENGTH_BOUNDS[suite]


def most_over(suite: str, n: int) -> int:
    """The most of ``n`` episodes that may be over the bound: more has probability <= ALPHA at
    the upper end of the committed share's 95% interval."""
    over, total = _over_share(suite)
    q = wilson_interval(over, total)[1]
    k = 0
    while 1.0 - binomial_cdf(k, n, q) > ALPHA:
        k += 1
    return k


def test_the_sample_covers_every_bounded_suite() -> None:
    assert set(SAMPLE) == set(LENGTH_BOUNDS)


@pytest.mark.parametrize("suite", sorted(SAMPLE))
def test_demonstrations_keep_their_pace(suite: str) -> None:
    lengths = []
    for index in SAMPLE[suite]:
        task = get_task(f"{suite}/{index}")
        inits = task.init_states()
        with LiberoEnv(task, EnvConfig(cameras=())) as env:
            expert = Expert(env)
            for i in STARTS:
                reset_seed, seed = episode_seeds(SEED, task.id, i)
                episode = expert.run(inits[i], reset_seed=reset_seed, seed=seed)
                if episode.success:
                    lengths.append(episode.length)
    assert lengths, f"{suite}: none of {2 * len(STARTS)} episodes succeeded"
    bound = LENGTH_BOUNDS[suite]
    over = [n for n in lengths if n > bound]
    allowed = most_over(suite, len(lengths))
    assert len(over) <= allowed, (
        f"{suite}: {len(over)} of {len(lengths)} successful episodes took more than {bound} steps "
        f"({sorted(lengths)}); the committed table allows at most {allowed}"
    )
