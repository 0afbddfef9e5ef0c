"""The scripted expert as a demonstration source: each slot's episode is searched in a worker
(attempts with new seeds until one succeeds within the request's length bound), and the card
says where the episodes started."""

from __future__ import annotations

from typing import TYPE_CHECKING

from libero_data.cards.card import EXPERT_SECTIONS, EXPERT_SUCCESS
from libero_data.pipeline.episodes import env_settings, expert_env
from libero_data.pipeline.request import STORED_INITS
from libero_data.pipeline.sources.base import CardPart, DemoSource, EpisodeRecord, register_source
from libero_data.seeding import demo_key, episode_seeds
from libero_data.sim.arm import ARM_INIT_NOISE
from libero_data.tasks.plus import episode_owner

if TYPE_CHECKING:
    from libero_data.experts.expert import Episode, Expert
    from libero_data.pipeline.request import GenerateRequest, Slot
    from libero_data.runtime.jobs import WorkerCache
    from libero_data.sim import LiberoEnv
    from libero_data.tasks.suites import Task


class ScriptedExpert(DemoSource):
    """The scripted expert (:mod:`libero_data.experts`): makes any request's episodes, so it is
    asked last."""

    order = 100
    records_after_goal = True

    def claims(self, request: GenerateRequest) -> bool:
        return True

    def search(self, cache: WorkerCache, task: Task, request: GenerateRequest, slot: Slot) -> EpisodeRecord:
        env, expert = expert_env(cache, task, *env_settings(request, task))
        return search_slot(env, expert, task, request, slot)

    def card(self, request: GenerateRequest, suite: str, infos: list[dict[str, object]]) -> CardPart:
        return CardPart(
            summary=f"Scripted demonstrations of the LIBERO suite `{suite}`, made with libero-data in LeRobot v3 format.",
            start_note=start_note(request.starts, request.episodes_per_task, request.arm_noise),
            sections=EXPERT_SECTIONS,
            success=EXPERT_SUCCESS,
        )


register_source(ScriptedExpert("scripted"))


def search_slot(
    env: LiberoEnv, expert: Expert, task: Task, request: GenerateRequest, slot: Slot
) -> EpisodeRecord:
    """Run attempts until one succeeds within the length bound; the record of the kept (or last)
    attempt. An attempt the bound stops (``expert`` is built to stop there) or that reaches the
    goal only after it is a failed attempt, counted in the record's ``too_long``."""
    from libero_data.numerics import machine_fingerprint
    from libero_data.provenance import expert_code

    stored = task.init_states() if task.init_states_path is not None else None
    bound = request.length_bound(task)
    code = expert_code()
    machine = machine_fingerprint()
    failures: list[str] = []
    too_long = 0
    for attempt in range(request.max_attempts):
        reset_seed, expert_seed = episode_seeds(request.seed, demo_key(*episode_owner(task), slot.k), attempt)
        index = request.stored_start(slot.k, 0 if stored is None else len(stored))
        if index is not None and stored is not None:
            init_index, init = index, stored[index]
        else:
            init_index, init = -1, None  # LIBERO's own placement sampler, from reset_seed
        episode = expert.run(init, reset_seed=reset_seed, seed=expert_seed)
        over = over_bound(episode.success, episode.length, bound)
        goal_step = episode.length if request.after_goal else 0
        if episode.success and over is None and request.after_goal:
            kept = after_goal(env, episode, request.after_goal)
            if kept is None:
                failures.append(f"the goal did not hold for the {request.after_goal} steps after it")
                continue
            episode = kept
        if episode.success and over is None:
            return EpisodeRecord(
                success=True,
                attempts=attempt + 1,
                failures=tuple(failures),
                code=code,
                machine=machine,
                init_index=init_index,
                reset_seed=reset_seed,
                expert_seed=expert_seed,
                actions=episode.actions,
                states=episode.states,
                final_state=episode.final_state,
                plan=tuple(episode.plan),
                too_long=too_long,
                goal_step=goal_step,
            )
        too_long += over is not None
        failures.append(over or episode.failure or "unknown")
    return EpisodeRecord(
        success=False,
        attempts=request.max_attempts,
        failures=tuple(failures),
        code=code,
        machine=machine,
        too_long=too_long,
    )


def after_goal(env: LiberoEnv, episode: Episode, steps: int) -> Episode | None:
    """``episode`` (just ended at its goal, ``env`` in its final state) with ``steps`` more steps:
    the arm held where it is (no motion asked) and the gripper as the last action left it; None
    where the goal no longer holds after them (an object still rolling off its target)."""
    import dataclasses

    import numpy as np

    hold = np.zeros(episode.actions.shape[1], dtype=np.float32)
    hold[-1] = episode.actions[-1, -1]
    states = []
    for _ in range(steps):
        states.append(env.get_state())
        env.advance(hold)
    if not env.success():
        return None
    phases = {**episode.phases, "after the goal": steps}
    return dataclasses.replace(
        episode,
        actions=np.concatenate([episode.actions, np.tile(hold, (steps, 1))]),
        states=np.concatenate([episode.states, np.asarray(states, dtype=episode.states.dtype)]),
        final_state=env.get_state(),
        phases=phases,
    )


def over_bound(success: bool, length: int, bound: int | None) -> str | None:
    """Why an attempt of ``length`` steps fails the length ``bound``, or None where it does not:
    it reached the goal after the bound, or it was still going at the bound (the expert stops
    there; whether it would have succeeded later is not known)."""
    if bound is None:
        return None
    if success and length > bound:
        return f"longer than the {bound}-step length bound (reached the goal after {length} steps)"
    if not success and length >= bound:
        return f"longer than the {bound}-step length bound (stopped at step {length} without the goal)"
    return None


#: The card's settings row for each kind of start.
START_WORDS = {
    "sampler": "LIBERO's placement sampler, demonstration seeds (no stored init state)",
    "stored": "LIBERO's stored init states (the paper's evaluation starts), then the sampler",
}


def start_words(starts: str, arm_noise: float) -> str:
    """The card's settings row for the starts."""
    arm = f"arm joints + N(0, {arm_noise:g} rad)" if arm_noise else "the arm at LIBERO's initial pose"
    return f"{START_WORDS[starts]}; sampler starts: {arm}"


def arm_words(arm_noise: float) -> str:
    """How the card says a sampler start holds the arm."""
    if arm_noise == 0:
        return (
            "with the arm at LIBERO's initial pose (no noise: the stored init states have "
            f"{ARM_INIT_NOISE:g} rad per joint)"
        )
    return (
        f"with the arm's seven joints offset by Gaussian noise of {arm_noise:g} rad drawn from the same seed "
        f"(LIBERO's stored init states have {ARM_INIT_NOISE:g} rad; LIBERO's environment itself starts every reset "
        "from one arm pose)"
    )


def start_note(starts: str, episodes_per_task: int, arm_noise: float) -> str:
    """Where the card says the episodes started."""
    if starts == "sampler":
        return (
            "Every episode starts from a placement drawn by LIBERO's own sampler for its task, seeded from the "
            "demonstration seed stream (`reset_seed` in `meta/libero_episodes.jsonl`, `init_index` -1), "
            f"{arm_words(arm_noise)}. No episode "
            "starts from LIBERO's 50 stored init states, which the paper's evaluation uses, and libero-bench draws "
            "its held-out evaluation placements from another seed stream: a policy trained on this dataset is "
            "evaluated on starts it never saw."
        )
    stored = min(episodes_per_task, STORED_INITS)
    note = (
        f"The first {stored} episodes of each task start from LIBERO's stored init states (episode k from init "
        "state k), the states the paper's evaluation starts from: a policy evaluated on them has seen its starts "
        "in training. "
        + (
            f"Further episodes start from placements drawn by LIBERO's own sampler for that task, seeded, {arm_words(arm_noise)}."
            if episodes_per_task > STORED_INITS
            else ""
        )
    )
    return note.strip()
