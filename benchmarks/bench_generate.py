"""Generation throughput and where its time goes; one worker against two.

One in-process ``generate`` run (``--workers 1``) over ``--tasks`` of ``--suite`` with
``--episodes`` episodes each, timed by wrapping the stages in place:

- **physics**: ``LiberoEnv._physics_step`` (robosuite's control step; search and settling);
- **expert**: the rest of ``Expert.run`` (planning, grasp search, skill logic);
- **rendering**: ``LiberoEnv.render`` (MuJoCo/OpenGL, both cameras of every kept frame);
- **frame assembly**: the rest of rendering an episode from its states (restoring each
  state, building the observation, checking the goal);
- **encoding**: handing frames to the video encoder's threads (``libero_data.record.encoder``),
  which encode while later frames render;
- **writing**: the rest of writing an episode in the generating thread (LeRobot's frame
  buffer) and waiting for the background shard writer. That thread completes each shard
  (flushing the videos, parquet, MCAP, fsync) while the next episode is searched and
  rendered, so it costs wall time only where the generating thread waits for it or where
  it slows that thread down (which shows in the other stages);
- **publishing**: merging finished episodes into the dataset and writing the card;
- **environment construction**: building each task's simulation (``LiberoEnv``), once per
  worker and task: start-up, not per-episode work;
- **other**: wall time not in any of the above (resets, scheduling; imports in the first run).

The overhead target (all but physics and rendering ≤ 10% of wall time) is stated for the
episodes, start-up excluded, since a real run's tasks have tens of episodes each; the
share over the whole short run, start-up included, is shown beside it.

Then the scaling: the same request in a fresh folder and a fresh Python process (wall time
only), with one worker pinned to one core (one llvmpipe thread), one worker with Mesa's
default of one rendering thread per core, two workers with that default, and two workers
rendering on one thread each; the configurations take turns. Each run also reports when its
first episode landed (start-up) and how long its last episode ran alone (the tail).
``--part side-by-side`` measures the ceiling for any two workers: one pinned single-worker
run alone against two independent ones at once, each pinned to its own core.
Everything is measured on the same machine in the same run; prints a Markdown table and,
with ``--results``, replaces this benchmark's section of ``benchmarks/RESULTS.md``.
"""

from __future__ import annotations

import argparse
import os
import shutil
import statistics
import tempfile
import threading
import time
from collections import defaultdict
from collections.abc import Callable
from pathlib import Path
from typing import Any

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("SVT_LOG", "1")

from benchmarks.results import growth_summary, status_mib

STAGES = (
    "physics",
    "expert",
    "rendering",
    "frame assembly",
    "encoding",
    "writing",
    "publishing",
    "environment construction",
    "other",
)


class Timers:
    """Accumulated seconds per stage; nested stages are subtracted from their parents."""

    def __init__(self) -> None:
        self.total: dict[str, float] = defaultdict(float)
        self.calls: dict[str, int] = defaultdict(int)

        self.writing_shard = False  # set while render_shard runs

    def wrap(
        self, owner: Any, name: str, stage: str, when: Callable[[], bool] | None = None
    ) -> Callable[[], None]:
        """Time ``owner.name`` as ``stage`` (only while ``when()`` holds, if given)."""
        original = getattr(owner, name)
        timers = self

        def timed(*args: Any, **kwargs: Any) -> Any:
            # Only the generating thread's time: work in the background shard writer
            # overlaps it and shows in the wall time only by what it delays.
            if (when is not None and not when()) or threading.current_thread() is not threading.main_thread():
                return original(*args, **kwargs)
            start = time.perf_counter()
            try:
                return original(*args, **kwargs)
            finally:
                timers.total[stage] += time.perf_counter() - start
                timers.calls[stage] += 1

        setattr(owner, name, timed)
        return lambda: setattr(owner, name, original)


def measure_split(suite: str, tasks: list[int], episodes: int, size: int, seed: int) -> dict[str, Any]:
    import libero_data.pipeline.generate as gen
    import libero_data.record.shard as shard
    from libero_data.experts.expert import Expert
    from libero_data.pipeline.generate import generate, resolve_request
    from libero_data.record.encoder import EpisodeVideoEncoder
    from libero_data.sim.env import LiberoEnv

    timers = Timers()
    in_shard = lambda: timers.writing_shard  # noqa: E731
    undo = [
        timers.wrap(LiberoEnv, "_physics_step", "physics"),
        timers.wrap(Expert, "run", "search"),
        timers.wrap(LiberoEnv, "render", "rendering"),
        # Restoring each stored state and building its observation (rendering included,
        # subtracted below), only while an episode is rendered and written.
        timers.wrap(LiberoEnv, "set_state", "assembly", when=in_shard),
        timers.wrap(LiberoEnv, "observe", "assembly", when=in_shard),
        timers.wrap(LiberoEnv, "success", "assembly", when=in_shard),
        timers.wrap(EpisodeVideoEncoder, "feed_frame", "encoding"),
        timers.wrap(EpisodeVideoEncoder, "finish_episode", "encoding"),
        timers.wrap(gen, "_publish", "publishing"),
        # Waiting for the background writer to complete the previous episode's shard.
        timers.wrap(gen, "wait_for_shard", "shard wait"),
        timers.wrap(LiberoEnv, "__init__", "construction"),
    ]
    shard_original = shard.render_shard

    def render_shard_timed(*args: Any, **kwargs: Any) -> Any:
        timers.writing_shard = True
        start = time.perf_counter()
        try:
            return shard_original(*args, **kwargs)
        finally:
            timers.total["write_shard"] += time.perf_counter() - start
            timers.writing_shard = False

    shard.render_shard = render_shard_timed
    undo.append(lambda: setattr(shard, "render_shard", shard_original))
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
        "frame assembly": t["assembly"] - t["rendering"],
        "encoding": t["encoding"],
        "writing": t["write_shard"] - t["assembly"] - t["encoding"] + t["shard wait"],
        "publishing": t["publishing"],
        "environment construction": t["construction"],
    }
    split["other"] = wall - sum(split.values())
    return {"wall": wall, "split": split, "episodes": progress.published, "frames": frames}


def wall_with_workers(
    suite: str, tasks: list[int], episodes: int, size: int, seed: int, workers: int
) -> dict[str, float]:
    """Wall time of one ``generate`` run, with the moments its episodes landed: ``first`` (pool
    start-up, imports and environment construction before any episode) and ``tail`` (from the
    next-to-last episode to the end: the last job alone, plus the final publish)."""
    from libero_data.pipeline.generate import generate, resolve_request

    request = resolve_request(
        suite, [str(t) for t in tasks], episodes_per_task=episodes, image_size=size, seed=seed
    )
    out = Path(tempfile.mkdtemp(prefix="bench-generate-")) / "d"
    landed: list[float] = []
    seen = 0

    def on_progress(progress: Any) -> None:
        nonlocal seen
        while seen < progress.done + progress.failed:
            landed.append(time.perf_counter())
            seen += 1

    try:
        start = time.perf_counter()
        generate(request, out, workers=workers, publish_every=1e9, on_progress=on_progress)
        end = time.perf_counter()
        return {
            "wall": end - start,
            "first": (landed[0] - start) if landed else float("nan"),
            "tail": (end - landed[-2]) if len(landed) > 1 else float("nan"),
        }
    finally:
        shutil.rmtree(out.parent, ignore_errors=True)


def _start_fresh_process(
    args: argparse.Namespace, workers: int, render_threads: int | None, cpu: int | None
) -> Any:
    import subprocess
    import sys

    env = dict(os.environ)
    env.pop("LP_NUM_THREADS", None)
    if render_threads is not None:
        env["LP_NUM_THREADS"] = str(render_threads)
    command = [
        sys.executable, "-m", "benchmarks.bench_generate", "--suite", args.suite,
        "--tasks", ",".join(map(str, args.tasks)), "--episodes", str(args.episodes),
        "--size", str(args.size), "--seed", str(args.seed), "--wall-only", str(workers),
    ]  # fmt: skip
    pin = (lambda: os.sched_setaffinity(0, {cpu})) if cpu is not None else None
    return subprocess.Popen(
        command, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, preexec_fn=pin
    )


def _times_of(process: Any) -> dict[str, float]:
    import json
    import subprocess

    out, err = process.communicate()
    if process.returncode != 0:
        raise subprocess.CalledProcessError(process.returncode, process.args, out, err)
    return dict(json.loads(out.strip().splitlines()[-1]))


def _cpus() -> list[int]:
    return sorted(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else [0]


def wall_in_fresh_process(
    args: argparse.Namespace, workers: int, render_threads: int | None, one_core: bool = False
) -> dict[str, float]:
    """``wall_with_workers`` in a new Python process (Mesa reads ``LP_NUM_THREADS`` once per
    process); ``render_threads`` None leaves Mesa's default (one per core). ``one_core`` pins
    the process and all its threads (rendering, video encoding, the background shard writer)
    to one CPU."""
    cpu = _cpus()[0] if one_core else None
    return _times_of(_start_fresh_process(args, workers, render_threads, cpu))


def pinned_side_by_side(args: argparse.Namespace) -> list[dict[str, float]]:
    """Two independent one-worker runs at once, each pinned to its own core (one llvmpipe
    thread): no pool, no shared work, so what slows each against running alone is what the
    two cores share (memory bandwidth, caches, the kernel), the ceiling for any two workers."""
    cpus = _cpus()
    if len(cpus) < 2:
        raise SystemExit("the side-by-side measurement needs two cores")
    running = [_start_fresh_process(args, 1, 1, cpu) for cpu in cpus[:2]]
    return [_times_of(p) for p in running]


def memory_trace(suite: str, task: int, episodes: int, size: int, seed: int) -> list[float]:
    """Resident MiB of the generating process after each of ``episodes`` episodes of one task.

    ``--workers 1`` searches and renders in this process, so it is the worker here; like the
    ``libero-data generate`` command in that case (and every pool worker), it first caps
    glibc's malloc arenas (see ``libero_data.runtime.memory``).
    """
    from libero_data.pipeline.generate import generate, resolve_request
    from libero_data.runtime.memory import limit_malloc_arenas

    limit_malloc_arenas()

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
        f"Run: `python -m benchmarks.bench_generate --suite {args.suite} --tasks {args.tasks[0]} --memory-episodes "
        f"{args.memory_episodes} --size {args.size}` (task {args.tasks[0]}, one process that searches and "
        "renders, two cameras; resident memory sampled after each episode).\n\n"
        + growth_summary(trace, "episodes")
        + "\n"
    )


def split_table(r: dict[str, Any], args: argparse.Namespace) -> str:
    wall, split = r["wall"], r["split"]
    lines = [
        f"Run: `python -m benchmarks.bench_generate --suite {args.suite} --tasks {','.join(map(str, args.tasks))} "
        f"--episodes {args.episodes} --size {args.size} --repeats {args.repeats} --part split` ({len(args.tasks)} tasks × "
        f"{args.episodes} episodes, two {args.size}² cameras, one process; the run with the median wall time of "
        f"{args.repeats}).",
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
    startup = split["environment construction"]
    episode_work = wall - startup
    per_task = startup / len(args.tasks)  # one worker builds each task's environment once
    per_episode = episode_work / max(r["episodes"], 1)
    rest = sum(v for k, v in split.items() if k not in ("physics", "rendering", "environment construction"))
    lines += [
        f"| **all but physics and rendering, per episode** (start-up excluded: share of the "
        f"{episode_work:.1f} s of episode work) | {rest:.1f} | **{rest / episode_work:.1%}** (target ≤ 10%) |",
        f"| all but physics and rendering over this whole run, start-up included | {rest + startup:.1f} | "
        f"{(rest + startup) / wall:.1%} |",
        "",
        f"Start-up is {per_task:.1f} s of environment construction per task and worker; "
        f"over a task of 50 episodes at this run's pace ({per_episode:.0f} s each) "
        f"that is {per_task / (per_task + 50 * per_episode):.1%} "
        "of the wall time.",
    ]
    return "\n".join(lines) + "\n"


def scaling_table(times: dict[str, dict[str, float]], cores: int, args: argparse.Namespace) -> str:
    base = times["1x1"]["wall"]
    rows = [
        ("1 (pinned to one core)", "1", "1x1"),
        ("1", f"{cores} (default)", "1"),
        ("2", f"{cores} (default)", "2"),
        ("2", "1", "2x1"),
    ]
    episodes = len(args.tasks) * args.episodes
    lines = [
        f"Run: `python -m benchmarks.bench_generate --suite {args.suite} --tasks {','.join(map(str, args.tasks))} "
        f"--episodes {args.episodes} --size {args.size} --repeats {args.repeats} --part scaling`.",
        "",
        f"Worker scaling over {episodes} episodes, each run in a fresh process (llvmpipe reads its "
        f"thread count once per process), medians of {args.repeats} runs taking turns; this machine "
        f"has {cores} cores. One worker renders with llvmpipe's default of one thread per core, and "
        "completes each shard in a background thread while it searches the next episode, so it "
        "already uses the other core for part of its work; the first row pins it, every thread "
        "included, to one core. *First episode*: from the start of the run to the first episode "
        "on disk (start-up: process pool, imports, environment construction, plus one episode). "
        "*Tail*: from the next-to-last episode to the end (the last job alone, and the final "
        "publish).",
        "",
        "| workers | llvmpipe threads per worker | wall s | first episode s | tail s | speed-up vs pinned one worker | vs one default worker |",
        "|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for workers, threads, key in rows:
        t = times[key]
        lines.append(
            f"| {workers} | {threads} | {t['wall']:.0f} | {t['first']:.0f} | {t['tail']:.0f} | "
            f"{base / t['wall']:.2f}× | {times['1']['wall'] / t['wall']:.2f}× |"
        )
    return "\n".join(lines) + "\n"


def side_by_side_table(alone: list[float], pairs: list[list[float]], args: argparse.Namespace) -> str:
    solo = statistics.median(alone)
    each = statistics.median(w for pair in pairs for w in pair)
    slowest = statistics.median(max(pair) for pair in pairs)
    lines = [
        f"Run: `python -m benchmarks.bench_generate --suite {args.suite} --tasks {','.join(map(str, args.tasks))} "
        f"--episodes {args.episodes} --size {args.size} --repeats {args.repeats} --part side-by-side`.",
        "",
        "The ceiling for two workers on this machine. One run of one worker pinned to one core (one "
        "llvmpipe thread), alone; then two such runs at the same time, each in its own process "
        "pinned to its own core: no pool, nothing shared but the hardware and the kernel. Medians "
        f"of {args.repeats}, taking turns.",
        "",
        "| runs | wall s (each) | throughput vs one alone |",
        "|---|---:|---:|",
        f"| one, alone | {solo:.0f} | 1.00× |",
        f"| two at once | {each:.0f} (slower of the two: {slowest:.0f}) | {2 * solo / slowest:.2f}× |",
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
    parser.add_argument(
        "--part",
        choices=("split", "scaling", "side-by-side", "all"),
        default="all",
        help="The time split of one worker (section Generation), worker scaling (section "
        "Generation scaling), both, or the ceiling for two workers: one pinned worker alone "
        "against two independent pinned workers at once (section Generation side by side).",
    )
    parser.add_argument("--results", type=Path, help="RESULTS.md to update")
    parser.add_argument("--wall-only", type=int, default=0, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.wall_only:  # one timed run for wall_in_fresh_process
        import json

        times = wall_with_workers(args.suite, args.tasks, args.episodes, args.size, args.seed, args.wall_only)
        print(json.dumps(times))
        return
    if args.memory_episodes:
        text = memory_table(
            memory_trace(args.suite, args.tasks[0], args.memory_episodes, args.size, args.seed), args
        )
        print(text)
        if args.results:
            from benchmarks.results import replace_section

            replace_section(args.results, "Generation memory", text)
        return
    from benchmarks.results import replace_section

    if args.part in ("split", "all"):
        # The split run with the median wall time of --repeats.
        splits = sorted(
            (
                measure_split(args.suite, args.tasks, args.episodes, args.size, args.seed)
                for _ in range(args.repeats)
            ),
            key=lambda r: r["wall"],
        )
        text = split_table(splits[len(splits) // 2], args)
        print(text)
        if args.results:
            replace_section(args.results, "Generation", text)
    if args.part == "side-by-side":
        alone: list[float] = []
        pairs: list[list[float]] = []
        for _ in range(args.repeats):
            alone.append(wall_in_fresh_process(args, 1, 1, one_core=True)["wall"])
            pairs.append([t["wall"] for t in pinned_side_by_side(args)])
            print("alone", alone[-1], "pair", pairs[-1], flush=True)
        text = side_by_side_table(alone, pairs, args)
        print(text)
        if args.results:
            replace_section(args.results, "Generation side by side", text)
    if args.part in ("scaling", "all"):
        cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1
        configs = {
            "1x1": (1, 1, True),
            "1": (1, None, False),
            "2": (2, None, False),
            "2x1": (2, 1, False),
        }
        runs: dict[str, list[dict[str, float]]] = {name: [] for name in configs}
        for _ in range(args.repeats):  # the configurations take turns, so load changes hit all alike
            for name, (workers, threads, one_core) in configs.items():
                runs[name].append(wall_in_fresh_process(args, workers, threads, one_core))
                print(name, runs[name][-1], flush=True)
        medians = {
            name: {key: statistics.median(r[key] for r in v) for key in ("wall", "first", "tail")}
            for name, v in runs.items()
        }
        text = scaling_table(medians, cores, args)
        print(text)
        if args.results:
            replace_section(args.results, "Generation scaling", text)


if __name__ == "__main__":
    main()
