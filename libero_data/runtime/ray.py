"""Starting (or joining) Ray for the job runner. Ray is imported only here, and only when used."""

from __future__ import annotations

import logging
import os
from typing import Any

from libero_data.errors import ExecutorError


def start_ray(workers: int, address: str | None) -> tuple[Any, bool]:
    """The ``ray`` module, initialised; and whether this call started it (then shut it down).

    Joins the cluster at ``address``, or starts a Ray instance here with ``workers`` CPUs.
    Workers get one OpenMP thread, this process's OpenGL backend and its numeric path
    (``libero_data.numerics``: the variables are read when a worker first loads NumPy).
    """
    from libero_data.numerics import NUMERIC_VARIABLES

    try:
        import ray
    except ImportError as exc:
        raise ExecutorError(
            "running on Ray needs Ray: pip install 'libero-data[ray]' (or ray>=2.40)", field="executor"
        ) from exc
    if ray.is_initialized():
        return ray, False
    # MALLOC_ARENA_MAX: see libero_data.runtime.memory (Ray starts the worker processes).
    env_vars = {"OMP_NUM_THREADS": "1", "SVT_LOG": "1", "MALLOC_ARENA_MAX": "2"}
    for name in ("MUJOCO_GL", *NUMERIC_VARIABLES):
        if os.environ.get(name):
            env_vars[name] = os.environ[name]
    options: dict[str, Any] = {
        "include_dashboard": False,
        "log_to_driver": False,
        "logging_level": logging.WARNING,
        "runtime_env": {"env_vars": env_vars},
    }
    if address:
        ray.init(address=address, **options)
    else:
        ray.init(num_cpus=max(workers, 1), **options)
    return ray, True
