"""What an evaluation rolls out: a LeRobot policy folder, loaded here, or a policy served
elsewhere (``ws://HOST:PORT``), and how each is opened as a batch actor."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from libero_bench.rollouts.actors import BatchActor

SERVER_SCHEMES = ("ws://", "wss://")


def is_server(policy: str) -> bool:
    """Whether ``policy`` names a policy server (``ws://HOST:PORT``) rather than a folder."""
    return policy.startswith(SERVER_SCHEMES)


@dataclass(frozen=True)
class PolicySource:
    """What is evaluated and how its inputs are made: its name and type for the report, the
    camera size to render at, what each input reads, and how to open the actor."""

    ref: str
    policy_type: str
    render_size: int
    inputs: dict[str, Any]
    open: Callable[[str], BatchActor]


def policy_source(policy: str, image_size: int | None = None, replan_steps: int = 5) -> PolicySource:
    """``policy``: a LeRobot folder (read now, loaded when rollouts start) or a server (reached
    now: an unreachable one is one sentence before any rollout); for a server, the image size
    sent and the actions executed of each chunk (``libero_bench.evaluation.policy_eval.EvalRequest``)."""
    if is_server(policy):
        from libero_bench.rollouts.remote import RemoteActor, connect

        connection, metadata = connect(policy, timeout=30.0)
        connection.close()
        served = metadata.get("image_size")
        size = image_size or (int(served) if isinstance(served, int) else 224)
        render = int(served) if isinstance(served, int) else max(size, 256)
        return PolicySource(
            policy,
            str(metadata.get("policy_type", "served")),
            render,
            {"server": policy, "image_size": size, "replan_steps": replan_steps},
            lambda _device: RemoteActor(policy, image_size=size, replan_steps=replan_steps),
        )
    from libero_bench.evaluation.lerobot_policy import lerobot_config, serve
    from libero_bench.rollouts.lerobot_actor import LeRobotActor

    folder = Path(policy).resolve()
    config = lerobot_config(folder)
    inputs = serve(config.input_features, f"the {config.type} policy at {folder}")
    return PolicySource(
        str(folder),
        config.type,
        inputs.render_size,
        {k: list(v) for k, v in {**inputs.cameras, **inputs.states}.items()},
        lambda device: LeRobotActor(folder, device),
    )


def check_policy(policy: str, image_size: int | None = None, replan_steps: int = 5) -> None:
    """One sentence, before anything is written or shown, where ``policy`` cannot be evaluated:
    a run folder with no finished task or a damaged or pickled checkpoint, a LeRobot folder with a
    bad config or weights, an unreachable server."""
    from libero_bench.runs.folder import RunFolder

    if not is_server(policy) and RunFolder(Path(policy)).is_run():
        from libero_bench.runs.folder import POLICY_FIELDS
        from libero_bench.runs.summary import load_run
        from libero_bench.train.checkpoints import kept_checkpoint, policy_from_checkpoint
        from libero_data.errors import RunError

        RunFolder(Path(policy)).read_config(needs=POLICY_FIELDS)
        summary = load_run(Path(policy))
        last = summary.tasks_done - 1
        if last < 0:
            raise RunError(
                f"the run {policy} has not finished learning a task yet: no checkpoint to evaluate"
            )
        # built and loaded once here: a config or checkpoint that does not fit is refused before any output
        checkpoint = kept_checkpoint(RunFolder(Path(policy)), summary.config, last)
        policy_from_checkpoint(summary.config, checkpoint, last)
        return
    policy_source(policy, image_size, replan_steps)
