"""A policy served elsewhere over openpi's websocket protocol (``ws://HOST:PORT``): reached now,
its metadata read (an unreachable server is one sentence before any rollout)."""

from __future__ import annotations

from libero_bench.rollouts.policy_kinds import (
    SERVER,
    PolicyKind,
    PolicySource,
    SourceOptions,
    is_server,
    register_kind,
)


def server_source(url: str, options: SourceOptions) -> PolicySource:
    """The source of the server at ``url``."""
    from libero_bench.rollouts.remote import RemoteActor, connect

    connection, metadata = connect(url, timeout=30.0)
    connection.close()
    served = metadata.get("image_size")
    size = options.image_size or (int(served) if isinstance(served, int) else 224)
    render = int(served) if isinstance(served, int) else max(size, 256)
    horizon = metadata.get("action_horizon")
    replan, request = options.replan_steps, options.request
    return PolicySource(
        url,
        SERVER,
        str(metadata.get("policy_type", "served")),
        render,
        {"server": url, "image_size": size, "replan_steps": replan},
        lambda _device, _view: RemoteActor(url, image_size=size, replan_steps=replan, request=request),
        chunk_size=int(horizon) if isinstance(horizon, int) else 1,
    )


register_kind(PolicyKind(SERVER, 0, is_server, server_source))
