"""Generation throughput and where its time goes; one worker against two.

One in-process ``generate`` run (``--workers 1``) over ``--tasks`` of ``--suite`` with
``--episodes`` episodes each, timed by wrapping the stages in place:

- **physics**: ``LiberoEnv._physics_step`` (robosuite's control step; search and settling);
- **expert**: the rest of ``Expert.run`` (planning, grasp search, skill logic);
- **rendering**: ``LiberoEnv.render`` (MuJoCo/OpenGL, both cameras of every kept frame);
- **frame assembly**: the rest of rendering an episode from its states (restoring each
  state, building the observation);
- **encoding**: LeRobot's video encoding: handing frames to its streaming encoder and
  waiting for the encoder threads to finish an episode (``StreamingVideoEncoder``);
- **writing**: the rest of writing an episode (LeRobot's frame buffer, parquet, MCAP,
  fsync);
- **publishing**: merging finished episodes into the dataset and writing the card;
- **other**: wall time not in any of the above (imports, environment construction, resets).

Then the same request again with ``--workers 2`` in a fresh folder (wall time only), for
the scaling ratio. Everything is measured on the same machine in the same run; prints a
Markdown table and, with ``--results``, replaces this benchmark's section of
``benchmarks/RESULTS.md``.
"""

from __future__ import annotations

import argparse
import os
import shutil
import statistics
import tempfile
import time
from collections import defaultdict
from collections.abc import Callable
from pathlib import Path
from typing import Any

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("SVT_LOG", "1")

from benchmarks.results import growth_summary, status_mib

STAGES = ("physics", "expert", "rendering", "frame assembly", "encoding", "writing", "publishing", "other")


class Timers:
    """Accumulated seconds per stage; nested stages are subtracted from their parents."""

    def __init__(self) -> None:
        self.total: dict[str, float] = defaultdict(float)
        self.calls: dict[str, int] = defaultdict(int)

    def wrap(self, owner: Any, name: str, stage: str) -> Callable[[], None]:
        original = getattr(owner, name)
        timers = self

        def timed(*args: Any, **kwargs: Any) -> Any:
            start = time.perf_counter()
            try:
                return original(*args, **kwargs)
            finally:
                timers.total[stage] += time.perf_counter() - start
                timers.calls[stage] += 1

        setattr(owner, name, timed)
        return lambda: setattr(owner, name, original)


def measure_split(suite: str, tasks: list[int], episodes: int, size: int, seed: int) -> dict[str, Any]:
    from lerobot.datasets.video_utils import StreamingVideoEncoder

    import libero_data.pipeline.generate as gen
    import libero_data.record.shard as shard
    from libero_data.experts.expert import Expert
    from libero_data.pipeline.generate import generate, resolve_request
    from libero_data.sim.env import LiberoEnv

    timers = Timers()
    undo = [
        timers.wrap(LiberoEnv, "_physics_step", "physics"),
        timers.wrap(Expert, "run", "search"),
        timers.wrap(LiberoEnv, "render", "rendering"),
        timers.wrap(shard, "render_frames", "render_frames"),
        timers.wrap(StreamingVideoEncoder, "feed_frame", "encoding"),
        timers.wrap(StreamingVideoEncoder, "finish_episode", "encoding"),
        timers.wrap(shard, "write_frames", "write_frames"),
        timers.wrap(gen, "_publish", "publishing"),
    ]
    request = resolve_request(
        suite, [str(t) for t in tasks], episodes_per_task=episodes, image_size=size, seed=seed
    )
    out = Path(tempfile.mkdtemp(prefix="bench-generate-")) / "d"
    physics_in_search: list[float] = []
    try:
        # Physics inside the search is attributed to physics, the rest of the search to the expert.
        search_original = Expert.run

        def run_and_split(self: Any, *args: Any, **kwargs: Any) -> Any:
            before = timers.total["physics"]
            result = search_original(self, *args, **kwargs)
            physics_in_search.append(timers.total["physics"] - before)
            return result

        Expert.run = run_and_split  # type: ignore[method-assign]
        start = time.perf_counter()
        progress = generate(request, out, workers=1, publish_every=1e9)
        wall = time.perf_counter() - start
        frames = timers.calls["rendering"] // 2
    finally:
        Expert.run = search_original  # type: ignore[method-assign]
        for u in reversed(undo):
            u()
        shutil.rmtree(out.parent, ignore_errors=True)
    t = timers.total
    split = {
        "physics": t["physics"],
        "expert": t["search"] - sum(physics_in_search),
        "rendering": t["rendering"],
        "frame assembly": t["render_frames"] - t["rendering"],
        "encoding": t["encoding"],
        "writing": t["write_frames"] - t["encoding"],
        "publishing": t["publishing"],
    }
    split["other"] = wall - sum(split.values())
    return {"wall": wall, "split": split, "episodes": progress.published, "frames": frames}


def wall_with_workers(
    suite: str, tasks: list[int], episodes: int, size: int, seed: int, workers: int
) -> float:
    from libero_data.pipeline.generate import generate, resolve_request

    request = resolve_request(
        suite, [str(t) for t in tasks], episodes_per_task=episodes, image_size=size, seed=seed
    )
    out = Path(tempfile.mkdtemp(prefix="bench-generate-")) / "d"
    try:
        start = time.perf_counter()
        generate(request, out, workers=workers, publish_every=1e9)
        return time.perf_counter() - start
    finally:
        shutil.rmtree(out.parent, ignore_errors=True)


def memory_trace(suite: str, task: int, episodes: int, size: int, seed: int) -> list[float]:
    """Resident MiB of the generating process after each of ``episodes`` episodes of one task.

    ``--workers 1`` searches and renders in this process, so it is the worker here.
    """
    from libero_data.pipeline.generate import generate, resolve_request

    request = resolve_request(suite, [str(task)], episodes_per_task=episodes, image_size=size, seed=seed)
    out = Path(tempfile.mkdtemp(prefix="bench-generate-mem-")) / "d"
    trace: list[float] = []
    seen = 0

    def on_progress(progress: Any) -> None:
        nonlocal seen
        finished = progress.done + progress.failed
        if finished > seen:
            seen = finished
            trace.append(status_mib(os.getpid(), "VmRSS"))

    try:
        generate(request, out, workers=1, publish_every=1e9, on_progress=on_progress)
        return trace
    finally:
        shutil.rmtree(out.parent, ignore_errors=True)


def memory_table(trace: list[float], args: argparse.Namespace) -> str:
    return (
        f"Run: `python -m benchmarks.bench_generate --suite {args.suite} --memory-episodes "
        f"{args.memory_episodes} --size {args.size}` (task {args.tasks[0]}, one process that searches and "
        "renders, two cameras; resident memory sampled after each episode).\n\n"
        + growth_summary(trace, "episodes")
        + "\n"
    )


def table(r: dict[str, Any], one: float, two: float, args: argparse.Namespace) -> str:
    wall, split = r["wall"], r["split"]
    lines = [
        f"Run: `python -m benchmarks.bench_generate --suite {args.suite} --tasks {','.join(map(str, args.tasks))} "
        f"--episodes {args.episodes} --size {args.size} --repeats {args.repeats}` ({len(args.tasks)} tasks × "
        f"{args.episodes} episodes, two {args.size}² cameras, one process; then 1 and 2 worker processes on a "
        f"fresh folder; the median of {args.repeats} runs each).",
        "",
        f"Kept episodes: {r['episodes']} in {wall:.0f} s = **{r['episodes'] / wall * 60:.1f} episodes/min** on one core; "
        f"rendered frames (both cameras): {r['frames']} = **{r['frames'] / wall:.1f} frames/s per core** over the "
        f"whole run, {r['frames'] / max(split['rendering'], 1e-9):.1f} frames/s while rendering.",
        "",
        "| stage | seconds | share of wall time |",
        "|---|---:|---:|",
    ]
    for stage in STAGES:
        lines.append(f"| {stage} | {split[stage]:.1f} | {split[stage] / wall:.1%} |")
    rest = sum(v for k, v in split.items() if k not in ("physics", "rendering"))
    lines += [
        f"| **all but physics and rendering** | {rest:.1f} | **{rest / wall:.1%}** (target ≤ 10%) |",
        "",
        "| workers | wall s | speed-up | target |",
        "|---:|---:|---:|---|",
        f"| 1 | {one:.0f} | 1.00 | |",
        f"| 2 | {two:.0f} | {one / two:.2f}× | ≥ 1.8× |",
    ]
    return "\n".join(lines) + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--suite", default="libero_object")
    parser.add_argument("--tasks", type=lambda s: [int(x) for x in s.split(",")], default=[0, 1])
    parser.add_argument("--episodes", type=int, default=2)
    parser.add_argument("--size", type=int, default=128)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument(
        "--repeats", type=int, default=3, help="Runs of each measurement; medians are reported."
    )
    parser.add_argument(
        "--memory-episodes",
        type=int,
        default=0,
        help="Only measure the generating process's memory over this many episodes of the first task.",
    )
    parser.add_argument("--results", type=Path, help="RESULTS.md to update")
    args = parser.parse_args()
    if args.memory_episodes:
        text = memory_table(
            memory_trace(args.suite, args.tasks[0], args.memory_episodes, args.size, args.seed), args
        )
        print(text)
        if args.results:
            from benchmarks.results import replace_section

            replace_section(args.results, "Generation memory", text)
        return
    # Medians of --repeats runs: the split run with the median wall time, and median walls.
    splits = sorted(
        (
            measure_split(args.suite, args.tasks, args.episodes, args.size, args.seed)
            for _ in range(args.repeats)
        ),
        key=lambda r: r["wall"],
    )
    r = splits[len(splits) // 2]
    ones, twos = [], []
    for _ in range(args.repeats):
        ones.append(wall_with_workers(args.suite, args.tasks, args.episodes, args.size, args.seed, 1))
        twos.append(wall_with_workers(args.suite, args.tasks, args.episodes, args.size, args.seed, 2))
    one, two = statistics.median(ones), statistics.median(twos)
    text = table(r, one, two, args)
    print(text)
    if args.results:
        from benchmarks.results import replace_section

        replace_section(args.results, "Generation", text)


if __name__ == "__main__":
    main()
