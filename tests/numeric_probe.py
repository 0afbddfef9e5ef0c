"""What one process's numeric path simulates; run by tests/sim/test_numerics.py in subprocesses.

``python -m tests.numeric_probe fingerprint`` prints the machine fingerprint as JSON;
``python -m tests.numeric_probe episode`` adds the hashes of one expert episode and of a replay
of fixed random actions. The process pins its numeric path as the tools do, unless
``LIBERO_DATA_NUMERICS=native``.
"""

from __future__ import annotations

import hashlib
import json
import sys

from libero_data.numerics import machine_fingerprint, pin


def _digest(*arrays: object) -> str:
    import numpy as np

    h = hashlib.sha256()
    for a in arrays:
        h.update(np.ascontiguousarray(a).tobytes())
    return h.hexdigest()[:16]


def main() -> None:
    pinned = pin()
    out: dict[str, object] = {"pin": pinned, "fingerprint": machine_fingerprint()}
    if sys.argv[1:] == ["episode"]:
        import numpy as np

        from libero_data.experts import Expert
        from libero_data.sim import EnvConfig, LiberoEnv
        from libero_data.tasks import get_task

        task = get_task("libero_object/1")
        with LiberoEnv(task, EnvConfig(cameras=())) as env:
            episode = Expert(env).run(task.init_states()[0], reset_seed=3, seed=4)
            out["expert"] = [bool(episode.success), episode.length, _digest(episode.actions, episode.states)]
            env.reset(task.init_states()[2], seed=5, settle=10, render=False)
            rng = np.random.default_rng(7)
            states = []
            for _ in range(30):
                env.advance(np.concatenate([rng.uniform(-1, 1, 6), [rng.choice([-1.0, 1.0])]]))
                states.append(env.get_state())
            out["replay"] = _digest(np.array(states))
    print(json.dumps(out))


if __name__ == "__main__":
    main()
