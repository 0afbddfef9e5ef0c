"""Every seed this project derives, in one place.

A user gives one seed per command (``--seed``); everything random below it is derived here,
from that seed and the identity of the thing being made, never from the order work happens
to run in. So a result depends on the request only: not on ``--workers``, on Ray, on which
episodes an interrupted run had finished, or on the machine.

=====================================  ============================================================
what                                   derived from
=====================================  ============================================================
demonstration episode (``generate``)   ``episode_seeds(seed, "<suite>/<task name>/<k>", attempt)``
expert report episode                  ``episode_seeds(seed, "<suite>/<task index>", init index)``
procedural candidate: starts, expert   ``candidate_seed(seed, task name, i)``; the expert's
                                       ``candidate_seed(seed, task name, 1000 + i)``
procedural sampling                    ``sampler_rng(seed)``
robustness variant                     ``variant_rng(seed, task index, kind position)``
benchmark run: weights, task, loaders  ``run_seed(seed, task position, stream)``, streams below
a loader's epoch                       ``loader_epoch_seed(loader seed, epoch)``
evaluation rollout ``r``, stored start ``rollout_start(r, stored init states)``
evaluation rollout ``r``, held out     ``heldout_starts(task key, n, avoid)[r]``
a sampler start's arm pose             ``arm_noise_rng(reset seed)``
a sampling policy's noise (evaluation) ``policy_noise_seed(rollout key, chunk)``
reinforcement-learning start ``n``     ``training_start(seed, task key, n, stored init states)``
=====================================  ============================================================

An episode's two seeds are a *reset seed* (LIBERO places fixtures, and objects where no
stored init state is given) and an *expert seed* (the expert's style: grasp choices,
speeds). The derivations are frozen: changing one changes every dataset made since.
"""

from __future__ import annotations

import hashlib

import numpy as np

#: ``run_seed`` streams: initial weights (task 0), a task's start, its loader, the loader
#: the algorithm's ``end_task`` reads (Fisher, replay memory).
WEIGHTS, TASK_START, LOADER, END_TASK_LOADER = 0, 1, 2, 3
#: Offset of the expert's seeds from the starts' in ``candidate_seed``.
CANDIDATE_EXPERT = 1000
#: The held-out evaluation stream's tag: its seeds depend on the task only (every run of every
#: method is evaluated from the same placements), never on a dataset's or a run's seed.
HELDOUT_TAG = 0x4E1D0
#: The tag of the stream that draws a sampler start's arm-joint noise from its reset seed.
ARM_NOISE_TAG = 0xA4A
#: The tag of the stream a reinforcement-learning environment draws its starts from (apart from
#: the held-out evaluation stream, so a policy trained there is evaluated elsewhere).
TRAINING_TAG = 0x7EA1


def stable_hash(text: str) -> int:
    """32 bits of SHA-256 of ``text``: the same in every process (unlike ``hash``)."""
    return int.from_bytes(hashlib.sha256(text.encode()).digest()[:4], "little")


def episode_seeds(seed: int, task_key: str, index: int) -> tuple[int, int]:
    """(reset seed, expert seed) of one expert episode."""
    a, b = np.random.SeedSequence([seed, stable_hash(task_key), index]).generate_state(2)
    return int(a), int(b)


def demo_key(suite: str, task_name: str, k: int) -> str:
    """The ``task_key`` of episode ``k`` of a task in ``generate`` (its attempts are the index)."""
    return f"{suite}/{task_name}/{k}"


def candidate_seed(seed: int, task_name: str, i: int) -> int:
    """Seed ``i`` of a procedural candidate: its ``i``-th sampled start, or (from
    :data:`CANDIDATE_EXPERT` on) the expert's seed for that start."""
    return int(np.random.SeedSequence([seed, stable_hash(task_name), i]).generate_state(1)[0])


def sampler_rng(seed: int) -> np.random.Generator:
    """The stream that draws procedural tasks (templates, scenes, objects, placements)."""
    return np.random.default_rng(np.random.SeedSequence([seed, 0x11BE70]))


def arm_noise_rng(reset_seed: int) -> np.random.Generator:
    """The stream of the arm's joint noise of a start placed by LIBERO's sampler from ``reset_seed``."""
    return np.random.default_rng(np.random.SeedSequence([int(reset_seed) & 0xFFFFFFFF, ARM_NOISE_TAG]))


def variant_rng(seed: int, task_index: int, kind_position: int) -> np.random.Generator:
    """The stream of one robustness variant of a shipped task."""
    return np.random.default_rng(np.random.SeedSequence([seed, task_index, kind_position, 0x7A51]))


def variant_level_rng(seed: int, task_index: int, kind_position: int, level: int) -> np.random.Generator:
    """The stream of a robustness variant at a severity level (level 1 is :func:`variant_rng`'s
    stream, so variants made before levels existed are made again the same)."""
    if level == 1:
        return variant_rng(seed, task_index, kind_position)
    return np.random.default_rng(np.random.SeedSequence([seed, task_index, kind_position, 0x7A51, level]))


def run_seed(seed: int, task: int, stream: int) -> int:
    """A 63-bit seed of a benchmark run for ``task`` (its position in the run) and ``stream``
    (:data:`WEIGHTS`, :data:`TASK_START`, :data:`LOADER`, :data:`END_TASK_LOADER`)."""
    value = 0x9E3779B97F4A7C15
    for part in (seed, task, stream):
        value = (value ^ (int(part) & 0xFFFFFFFFFFFFFFFF)) * 0xBF58476D1CE4E5B9 & 0xFFFFFFFFFFFFFFFF
        value ^= value >> 31
    return value & 0x7FFFFFFFFFFFFFFF


def loader_epoch_seed(seed: int, epoch: int) -> int:
    """The seed that shuffles epoch ``epoch`` of a training loader seeded with ``seed``."""
    return (seed * 1_000_003 + epoch) % 2**63


def rollout_start(rollout: int, stored: int) -> tuple[int, int]:
    """(init state index, fixture seed) of evaluation rollout ``rollout`` of a task with
    ``stored`` init states; index -1 where there are none (objects placed from the seed).
    The same for every epoch and checkpoint, so evaluations compare like with like."""
    return (rollout % stored if stored > 0 else -1), rollout


def training_start(seed: int, task_key: str, n: int, stored: int) -> tuple[int, int]:
    """(init state index, reset seed) of start ``n`` of a reinforcement-learning environment
    seeded with ``seed``: a stored init state drawn uniformly (index -1 where ``stored`` is 0:
    LIBERO's sampler places the objects from the reset seed)."""
    a, b = np.random.SeedSequence(
        [int(seed) & 0xFFFFFFFFFFFFFFFF, TRAINING_TAG, stable_hash(task_key), n]
    ).generate_state(2)
    return (int(a) % stored if stored > 0 else -1), int(b)


def policy_noise_seed(rollout_key: str, chunk: int) -> int:
    """The seed of the noise a sampling policy (Diffusion Policy) draws for action chunk ``chunk``
    of one evaluation rollout: a rollout's actions then do not depend on which other rollouts
    shared its batch."""
    return int(np.random.SeedSequence([stable_hash(rollout_key), chunk]).generate_state(1)[0])


def heldout_seed(task_key: str, index: int) -> int:
    """Seed ``index`` of a task's held-out evaluation stream (``task_key``: ``suite/name``)."""
    return int(np.random.SeedSequence([HELDOUT_TAG, stable_hash(task_key), index]).generate_state(1)[0])


def heldout_starts(task_key: str, n: int, avoid: frozenset[int] | set[int] = frozenset()) -> list[int]:
    """The first ``n`` seeds of a task's held-out stream that are not in ``avoid`` (the reset
    seeds its training demonstrations started from): LIBERO's sampler places the objects and
    fixtures from each, so an evaluation never starts where a demonstration did."""
    seeds: list[int] = []
    index = 0
    while len(seeds) < n:
        seed = heldout_seed(task_key, index)
        if seed not in avoid:
            seeds.append(seed)
        index += 1
    return seeds
