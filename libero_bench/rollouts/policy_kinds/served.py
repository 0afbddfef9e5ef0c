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
    from libero_bench.rollouts.observations import EXTRA_ENTRIES
    from libero_bench.rollouts.remote import RemoteActor, check_chunks, connect, served_extras

    connection, metadata = connect(url, timeout=30.0)
    connection.close()
    openpi = options.request == "openpi"
    if openpi:  # before the evaluation folder is claimed: a retry with other options is not blocked
        check_chunks(url, metadata, options.replan_steps)
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
        {
            "server": url,
            "image_size": size,
            "replan_steps": replan,
            **({"beyond_openpi": [EXTRA_ENTRIES[k] for k in served_extras(metadata)]} if openpi else {}),
        },
        lambda _device, _view: RemoteActor(url, image_size=size, replan_steps=replan, request=request),
        chunk_size=int(horizon) if isinstance(horizon, int) else 1,
    )


register_kind(PolicyKind(SERVER, 0, is_server, server_source))
