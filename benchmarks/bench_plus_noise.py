"""What LIBERO-Plus's image noise costs per frame: each corruption at its mildest and strongest
severity on a 256 x 256 agentview image (libero_object/0's first frame), median of 5, against
drawing the frame itself.

    python -m benchmarks.bench_plus_noise
"""

from __future__ import annotations

import statistics
import time

import numpy as np


def main() -> None:
    from libero_data.perturb.plus_noise import NAMES, corrupt
    from libero_data.sim.env import EnvConfig, LiberoEnv
    from libero_data.tasks import get_task

    task = get_task("libero_object/0")
    with LiberoEnv(task, EnvConfig(cameras=("agentview",), image_size=256)) as env:
        env.reset(task.init_states()[0], seed=0)
        draws = []
        for _ in range(5):
            start = time.perf_counter()
            image = env.render("agentview")
            draws.append(time.perf_counter() - start)
    draw = statistics.median(draws)
    print(f"drawing the 256 px agentview frame: {draw * 1000:.0f} ms")
    for k, name in enumerate(NAMES):
        for severity in (10 * k + 1, 10 * k + 10):
            times = []
            for rep in range(5):
                start = time.perf_counter()
                corrupt(image, severity, np.random.default_rng(rep))
                times.append(time.perf_counter() - start)
            t = statistics.median(times)
            print(f"{name:14s} noise {severity:2d}: {t * 1000:6.1f} ms ({t / draw:.2f}x the frame's drawing)")


if __name__ == "__main__":
    main()
