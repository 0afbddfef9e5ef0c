"""``render_quality="fast"`` against LIBERO's own renderer: speed, image difference, encoding error.

For each scene and image size, in one process. The scenes: one task of each of the five suites
(``--tasks``, task 0 of each by default), or with ``--sample N`` at least N tasks drawn with
``--seed``: one of every layout (the 20 kitchen, living-room and study scenes of libero_90 and
libero_10, and the tables of libero_spatial, libero_object and libero_goal), then one more of
any suite none was drawn from, then more at random up to N.

- **speed**: rendered steps (``step`` of a no-op action, both cameras) of LIBERO's
  ``OffScreenRenderEnv`` (the baseline) and of ``LiberoEnv`` at ``fast`` quality, and a step
  of ``LiberoEnv`` without cameras (physics); medians of ``--reps`` rounds of ``--frames``
  steps taking turns, so a change in the machine's load hits every measurement alike;
- **image difference**: ``fast`` against ``full`` images of the same states (the stored init
  state and the states along ``--states`` steps of a scripted push), mean and max |d| per
  camera on a 0-1 scale; ``full`` is drawn by the fast environment's reference renderer, which
  gives LIBERO's pixels exactly (``tests/sim/test_fast_render.py``);
- **encoding error**: the same ``full`` frames through the datasets' video encoder (LeRobot's
  AV1 settings) and back, mean |d| per camera: the error every dataset frame already carries;
- **where a fast step goes**: physics, then per camera the scene update, the draw and the pixel
  read-back, each run to completion (:func:`render_timed`), the triangles drawn,
  and the reflective surfaces in view (MuJoCo draws the whole scene again, mirrored, in the first
  of them; `fast` leaves that pass out for the wrist camera, whose draw is also timed with it).

Prints Markdown and, with ``--results``, replaces the "Fast rendering" section of
``benchmarks/RESULTS.md``. The simplified-mesh cache is built first (and timed) in a fresh
folder, so the run measures building it too.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import tempfile
import time
from pathlib import Path
from typing import TYPE_CHECKING, Any

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("SVT_LOG", "1")

import numpy as np

from benchmarks.bench_render import interleaved_rates

if TYPE_CHECKING:
    from libero_data.sim import LiberoEnv
    from libero_data.sim.fast.renderer import OffscreenRenderer

NOOP = np.array([0, 0, 0, 0, 0, 0, -1.0])
PUSH = np.array([0.3, -0.2, -0.25, 0.0, 0.0, 0.1, -1.0])
CAMERAS = ("agentview", "eye_in_hand")
TASKS = "libero_spatial/0,libero_object/0,libero_goal/0,libero_10/0,libero_90/0"
SUITES = ("libero_spatial", "libero_object", "libero_goal", "libero_10", "libero_90")


def cpu_model() -> str:
    """The CPU's model name (``/proc/cpuinfo``), or the platform's processor string."""
    import platform

    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown"


def layout(task: Any) -> str:
    """A task's scene layout: its libero_90/libero_10 scene (``KITCHEN_SCENE3``...), or its suite's table."""
    import re

    match = re.match(r"([A-Z_]+_SCENE\d+)_", task.name)
    return match.group(1) if match else task.suite


def sample_scenes(n: int, seed: int) -> list[str]:
    """At least ``n`` task references drawn with ``seed``: one of every layout, one of any suite
    left out, then more at random (see the module docstring); sorted by suite and index."""
    from libero_data.tasks import get_suite

    rng = np.random.default_rng(seed)
    tasks = [get_suite(s).task(i) for s in SUITES for i in range(len(get_suite(s)))]
    by_layout: dict[str, list[Any]] = {}
    for task in tasks:
        by_layout.setdefault(layout(task), []).append(task)
    chosen = [group[rng.integers(len(group))] for _, group in sorted(by_layout.items())]
    for suite in SUITES:
        if all(t.suite != suite for t in chosen):
            group = [t for t in tasks if t.suite == suite]
            chosen.append(group[rng.integers(len(group))])
    rest = [t for t in tasks if t not in chosen]
    for i in rng.permutation(len(rest))[: max(0, n - len(chosen))]:
        chosen.append(rest[int(i)])
    order = {s: k for k, s in enumerate(SUITES)}
    return [t.id for t in sorted(chosen, key=lambda t: (order[t.suite], t.index))]


def _with_sky(row: dict[str, Any], camera: str) -> str:
    """A camera's draw as ``fast`` makes it → with the sky (* where it was left out)."""
    mark = "*" if row[f"{camera}_sky_left_out"] else ""
    return f"{row[f'{camera}_draw'] * 1e3:.1f}{mark} → {row[f'{camera}_draw_sky'] * 1e3:.1f} ms"


def render_timed(renderer: OffscreenRenderer, model: Any, data: Any, camera_id: int) -> dict[str, float]:
    """What ``renderer.render`` spends, in its three parts, each run to completion (seconds):
    ``update`` (the scene's poses, and culling), ``draw`` (``mjr_render`` and the GL work it
    queued, finished) and ``read`` (the pixels back into memory), and ``triangles``: the mesh
    triangles in the scene drawn. The image is ``render``'s (``renderer.image()`` after)."""
    from OpenGL import GL

    renderer.make_current()
    GL.glFinish()
    start = time.perf_counter()
    renderer.update(model, data, camera_id)
    updated = time.perf_counter()
    left_out = renderer.draw(model, camera_id)
    GL.glFinish()
    drawn = time.perf_counter()
    renderer.read()
    read = time.perf_counter()
    return {
        "update": updated - start,
        "draw": drawn - updated,
        "read": read - drawn,
        "triangles": renderer.triangles(left_out),
    }


def fast_renderer_of(env: LiberoEnv, camera: str) -> OffscreenRenderer:
    """The ``fast`` renderer that draws ``camera`` of ``env`` (built on first use)."""
    if env.fast_images is None:
        raise ValueError("the environment renders at full quality")
    return env.fast_images.renderer(env.sim.model._model, env.camera_id(camera))


def render_parts(env: LiberoEnv, frames: int) -> dict[str, float]:
    """Medians over ``frames`` renders of each camera: update, draw and read-back seconds, the
    triangles drawn, and the reflective planes and boxes in the scene drawn (agentview)."""
    import mujoco

    model, data = env.sim.model._model, env.sim.data._data
    scene = fast_renderer_of(env, "agentview").scene
    mirrors = (int(mujoco.mjtGeom.mjGEOM_PLANE), int(mujoco.mjtGeom.mjGEOM_BOX))
    out: dict[str, float] = {}
    for camera in CAMERAS:
        own, camera_id = fast_renderer_of(env, camera), env.camera_id(camera)
        timed = [render_timed(own, model, data, camera_id) for _ in range(frames)]
        for part in timed[0]:
            out[f"{camera}_{part}"] = statistics.median(t[part] for t in timed)
        if camera == "agentview":  # the scene still holds agentview's last render
            geoms = [scene.geoms[k] for k in range(scene.ngeom)]
            out["reflective"] = sum(1 for g in geoms if g.reflectance > 0 and g.type in mirrors)
            out["lights"] = int(scene.nlight)
    # What the wrist camera's draw would cost with the mirror pass `fast` leaves out for it.
    wrist = env.camera_id("eye_in_hand")
    renderer = fast_renderer_of(env, "eye_in_hand")
    kept, renderer.unmirrored = renderer.unmirrored, frozenset()
    try:
        timed = [render_timed(renderer, model, data, wrist) for _ in range(frames)]
    finally:
        renderer.unmirrored = kept
    out["eye_in_hand_draw_mirrored"] = statistics.median(t["draw"] for t in timed)
    # ... and without the occlusion queries that leave out the large still meshes it cannot see
    # (the mirrored draw above has none either: they are only for cameras without the pass).
    queried, renderer.hidden = renderer.hidden, None
    try:
        timed = [render_timed(renderer, model, data, wrist) for _ in range(frames)]
    finally:
        renderer.hidden = queried
    out["eye_in_hand_draw_unqueried"] = statistics.median(t["draw"] for t in timed)
    out["eye_in_hand_triangles_unqueried"] = statistics.median(t["triangles"] for t in timed)
    # What agentview's draw would cost from the wrist's renderer: every mesh at 0.5 mm, the
    # distant ones included (the same renderer where the scene has no distant still mesh).
    front = env.camera_id("agentview")
    timed = [render_timed(renderer, model, data, front) for _ in range(frames)]
    out["agentview_draw_fine"] = statistics.median(t["draw"] for t in timed)
    out["agentview_triangles_fine"] = statistics.median(t["triangles"] for t in timed)
    # Each camera's draw with the sky, which `fast` leaves out where it is proved covered (.sky).
    sky = int(mujoco.mjtRndFlag.mjRND_SKYBOX)
    for camera in CAMERAS:
        own, camera_id = fast_renderer_of(env, camera), env.camera_id(camera)
        own.render(model, data, camera_id)
        out[f"{camera}_sky_left_out"] = float(not own.scene.flags[sky])
        cover, own.sky = own.sky, None
        own.scene.flags[sky] = 1
        try:
            timed = [render_timed(own, model, data, camera_id) for _ in range(frames)]
        finally:
            own.sky = cover
        out[f"{camera}_draw_sky"] = statistics.median(t["draw"] for t in timed)
    return out


def encoding_error(frames: list[np.ndarray]) -> float:
    """Mean |decoded - original| (0-1) of ``frames`` through the datasets' video encoder."""
    import av

    from libero_data.record.encoder import EpisodeVideoEncoder

    with tempfile.TemporaryDirectory() as tmp:
        encoder = EpisodeVideoEncoder(fps=20)
        encoder.start_episode(["camera"], Path(tmp))
        for frame in frames:
            encoder.feed_frame("camera", frame)
        path, _ = encoder.finish_episode()["camera"]
        with av.open(str(path)) as container:
            decoded = [f.to_ndarray(format="rgb24") for f in container.decode(video=0)]
    return float(
        np.mean([np.abs(d.astype(np.int16) - f).mean() for d, f in zip(decoded, frames, strict=True)]) / 255
    )


def measure(ref: str, size: int, frames: int, reps: int, states: int, cache: str) -> dict[str, Any]:
    import mujoco
    from libero.libero.envs import OffScreenRenderEnv

    from libero_data.sim import EnvConfig, LiberoEnv
    from libero_data.tasks import get_task

    task = get_task(ref)
    init = task.init_states()[0]
    out: dict[str, Any] = {"task": ref, "size": size, "layout": layout(task)}
    with (
        LiberoEnv(task, EnvConfig(image_size=size, render_quality="fast", mesh_cache=cache)) as fast,
        LiberoEnv(task, EnvConfig(cameras=())) as physics,
    ):
        fast.reset(init, seed=0, render=False)
        physics.reset(init, seed=0, render=False)
        start = time.perf_counter()
        fast.render("agentview")  # builds the simplified renderer (meshes from the cache)
        out["build_s"] = time.perf_counter() - start
        out.update({k: v for k, v in fast.render_scene().items() if k.startswith("faces")})
        # Image difference and encoding error on the same states.
        full_frames: dict[str, list[np.ndarray]] = {c: [] for c in CAMERAS}
        diffs: dict[str, list[np.ndarray]] = {c: [] for c in CAMERAS}
        fast.reset(init, seed=0, render=False)
        for i in range(states + 1):
            if i:
                fast.advance(PUSH)
            fast.set_state(fast.get_state())  # images of the state itself, as datasets render
            for c in CAMERAS:
                reference = fast.render_full(c)
                full_frames[c].append(reference)
                diffs[c].append(np.abs(fast.render(c).astype(np.int16) - reference))
        for c in CAMERAS:
            d = np.stack(diffs[c])
            out[f"{c}_mean"] = float(d.mean() / 255)
            out[f"{c}_max"] = float(d.max() / 255)
            out[f"{c}_over_8"] = float((d.max(axis=-1) > 8).mean())  # share of pixels off by > 8/255
            out[f"{c}_encoding"] = encoding_error(full_frames[c])
        # Where a fast render's time goes (before LIBERO's environment exists: closing it
        # leaves other GL contexts of the process unusable).
        fast.reset(init, seed=0, render=False)
        out.update(render_parts(fast, frames))
        # Speed, taking turns with LIBERO's own environment.
        libero = OffScreenRenderEnv(
            bddl_file_name=str(task.bddl_path),
            camera_heights=size,
            camera_widths=size,
            camera_names=["agentview", "robot0_eye_in_hand"],
        )
        try:
            libero.seed(0)
            libero.reset()
            libero.set_init_state(init)
            fast.reset(init, seed=0, render=False)
            gl = libero.env.sim._render_context_offscreen.gl_ctx
            own = {id(r): r for r in (fast_renderer_of(fast, c) for c in CAMERAS)}
            skies = {key: r.sky for key, r in own.items()}

            def sky_lever(on: bool) -> None:  # `fast` as it is, or drawing the sky in every frame
                for key, r in own.items():
                    r.sky = skies[key] if on else None
                    r.scene.flags[int(mujoco.mjtRndFlag.mjRND_SKYBOX)] = 1

            out.update(
                interleaved_rates(
                    {
                        "libero_step": lambda: libero.step(NOOP),
                        "fast_step": lambda: fast.step(NOOP),
                        "fast_step_sky": lambda: fast.step(NOOP),
                        "physics_step": lambda: physics.step(NOOP, render=False),
                        "fast_two_cameras": lambda: (fast.render("agentview"), fast.render("eye_in_hand")),
                    },
                    {
                        "libero_step": gl.make_current,
                        "fast_step": lambda: sky_lever(True),
                        "fast_step_sky": lambda: sky_lever(False),
                        "physics_step": lambda: sky_lever(True),
                    },
                    frames,
                    reps,
                )
            )
        finally:
            libero.close()
    return out


def generation_rates(task: str, episodes: int, size: int, repeats: int) -> dict[str, list[float]]:
    """Seconds of ``libero-data generate`` (one worker, a fresh folder and process each run) at
    full and fast render quality, taking turns; the same episodes either way."""
    import subprocess
    import sys

    suite, index = task.split("/")
    cli = str(Path(sys.executable).with_name("libero-data"))
    seconds: dict[str, list[float]] = {"full": [], "fast": []}
    with tempfile.TemporaryDirectory() as tmp:
        for r in range(repeats):
            for quality in seconds:
                out = Path(tmp) / f"{quality}-{r}"
                command = [cli, "generate", "--suite", suite, "--tasks", index, "--episodes-per-task"]
                command += [str(episodes), "--image-size", str(size), "--render-quality", quality]
                command += ["--out", str(out)]
                start = time.perf_counter()
                subprocess.run(command, check=True, capture_output=True)
                seconds[quality].append(time.perf_counter() - start)
    return seconds


def tables(
    rows: list[dict[str, Any]],
    args: argparse.Namespace,
    cache_s: float,
    cache_line: str,
    generation: dict[str, list[float]] | None,
) -> str:
    lines = [
        f"Two cameras (agentview, eye-in-hand) per step; medians of {args.reps} rounds × {args.frames} steps "
        "taking turns in one process; llvmpipe threads: "
        f"{os.environ.get('LP_NUM_THREADS', 'default (one per core)')}. Run: `python -m benchmarks.bench_render_fast "
        f"--sizes {','.join(map(str, args.sizes))} --frames {args.frames} --reps {args.reps} "
        f"--generate-episodes {args.generate_episodes}"
        + (f" --sample {args.sample} --seed {args.seed}" if args.sample else "")
        + f"`. CPU: {cpu_model()}. Shares of a fast step: physics, drawing (both cameras, finished), "
        "reading the pixels back, and the rest (scene updates, the step's own work). The last five columns, "
        "each lever alone: the wrist camera's draw as `fast` makes it and with MuJoCo's mirror pass, which "
        "`fast` leaves out for that camera (the same where the scene has no reflective surface; no occlusion "
        "queries either, which are only for cameras without the pass); the wrist's draw without the occlusion "
        "queries that leave out the large still meshes it cannot see (triangles drawn); agentview's draw as "
        "`fast` makes it and with every mesh at 0.5 mm (the wrist's renderer), triangles drawn; each camera's draw "
        "as `fast` makes it and with the sky, which it leaves out where proved covered (*: left out at that state); "
        "the step with the sky drawn in every frame, in the same rounds.",
        "",
        "| scene | layout | size | triangles, full → fast (drawn: agentview, wrist) | reflective, lights | LIBERO step ms | "
        "fast step ms | **fast / LIBERO** | physics | draw | read-back | other | wrist draw, with its mirror pass | "
        "wrist draw, without occlusion queries | agentview draw, with 0.5 mm distant meshes | "
        "draw with the sky: agentview, wrist | fast step with the sky (fast / LIBERO) |",
        "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for r in rows:
        step = r["fast_step"]
        draw = sum(r[f"{c}_draw"] for c in CAMERAS)
        read = sum(r[f"{c}_read"] for c in CAMERAS)
        other = step - r["physics_step"] - draw - read
        lines.append(
            f"| `{r['task']}` | {r['layout']} | {r['size']} | {r['faces_before'] / 1000:.0f} k → "
            f"{r['faces_after'] / 1000:.0f} k ({r['agentview_triangles'] / 1000:.0f} k, "
            f"{r['eye_in_hand_triangles'] / 1000:.0f} k) | {r['reflective']}, {r['lights']} | {r['libero_step'] * 1e3:.1f} | "
            f"{step * 1e3:.1f} | **{r['libero_step'] / step:.2f}×** | {r['physics_step'] / step:.0%} | "
            f"{draw / step:.0%} | {read / step:.0%} | {other / step:.0%} | "
            f"{r['eye_in_hand_draw'] * 1e3:.1f} → {r['eye_in_hand_draw_mirrored'] * 1e3:.1f} ms | "
            f"{r['eye_in_hand_draw'] * 1e3:.1f} → {r['eye_in_hand_draw_unqueried'] * 1e3:.1f} ms "
            f"({r['eye_in_hand_triangles'] / 1000:.0f} k → {r['eye_in_hand_triangles_unqueried'] / 1000:.0f} k) | "
            f"{r['agentview_draw'] * 1e3:.1f} → {r['agentview_draw_fine'] * 1e3:.1f} ms "
            f"({r['agentview_triangles'] / 1000:.0f} k → {r['agentview_triangles_fine'] / 1000:.0f} k) | "
            + (", ".join(_with_sky(r, c) for c in CAMERAS) if "agentview_draw_sky" in r else "–")
            + " | "
            + (
                f"{r['fast_step_sky'] * 1e3:.1f} ms ({r['libero_step'] / r['fast_step_sky']:.2f}×)"
                if "fast_step_sky" in r
                else "–"
            )
            + " |"
        )
    lines += [
        "",
        "| size | scenes | min | slowest tenth (10th percentile) | median | all scenes (total time) |",
    ]
    lines += ["|---:|---:|---:|---:|---:|---:|"]
    for size in args.sizes:
        mine = [r for r in rows if r["size"] == size]
        ratios = np.array([r["libero_step"] / r["fast_step"] for r in mine])
        total = sum(r["libero_step"] for r in mine) / sum(r["fast_step"] for r in mine)
        lines.append(
            f"| {size} | {len(mine)} | {ratios.min():.2f}× | {np.percentile(ratios, 10):.2f}× | "
            f"{np.median(ratios):.2f}× | {total:.2f}× |"
        )
    lines += [
        "",
        f"Image difference, `fast` against `full` on the same {args.states + 1} states per scene (stored init "
        "state, then a scripted push), and the error the datasets' AV1 encoding adds to the `full` frames "
        "themselves; |d| on a 0-1 scale, per camera:",
        "",
        "| scene | size | agentview mean | max | > 8/255 | encoding mean | eye-in-hand mean | max | > 8/255 | encoding mean |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for r in rows:
        cells = []
        for c in CAMERAS:
            cells += [
                f"{r[f'{c}_mean']:.4f}",
                f"{r[f'{c}_max']:.3f}",
                f"{r[f'{c}_over_8']:.1%}",
                f"{r[f'{c}_encoding']:.4f}",
            ]
        lines.append(f"| `{r['task']}` | {r['size']} | " + " | ".join(cells) + " |")
    worst = max(r[f"{c}_mean"] for r in rows for c in CAMERAS)
    best_enc = min(r[f"{c}_encoding"] for r in rows for c in CAMERAS)
    lines += [
        "",
        f"Largest mean difference: **{worst:.4f}**; smallest encoding error: **{best_enc:.4f}**.",
        "",
        f"Building the cache for these scenes from empty: {cache_s:.1f} s ({cache_line}).",
    ]
    if generation:
        full, fast = (statistics.median(generation[q]) for q in ("full", "fast"))
        n = args.generate_episodes
        lines += [
            "",
            f"Generation (`libero-data generate --suite {args.generate_task.split('/')[0]} --tasks "
            f"{args.generate_task.split('/')[1]} --episodes-per-task {n} --image-size {args.sizes[0]}`, one worker, "
            f"a fresh folder and process each run, medians of {len(generation['full'])} runs taking turns; the "
            "same episodes at either quality, the mesh cache already built): "
            f"full {full:.0f} s = **{60 * n / full:.2f} episodes/min**, fast {fast:.0f} s = "
            f"**{60 * n / fast:.2f} episodes/min** ({full / fast:.2f}×). Wall time includes start-up "
            "(imports, environment construction) and the search, which rendering does not change.",
        ]
    return "\n".join(lines) + "\n"


def _load_rows(path: Path | None) -> dict[tuple[str, int], dict[str, Any]]:
    """Rows measured before (``--rows``), by scene and size; a line cut off by an interruption is ignored."""
    rows: dict[tuple[str, int], dict[str, Any]] = {}
    if path is None or not path.is_file():
        return rows
    for line in path.read_text().splitlines():
        try:
            row = json.loads(line)
        except json.JSONDecodeError:
            continue
        rows[(row["task"], int(row["size"]))] = row
    return rows


def _append_row(path: Path, row: dict[str, Any]) -> None:
    """Add ``row`` as one line (NumPy scalars as numbers), on a line of its own even after a line
    an interruption cut off."""
    cut = path.is_file() and path.stat().st_size > 0 and not path.read_bytes().endswith(b"\n")
    with path.open("a") as f:
        f.write(("\n" if cut else "") + json.dumps(row, default=lambda v: v.item()) + "\n")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tasks", default=TASKS, help="comma-separated task references")
    parser.add_argument("--sample", type=int, default=0, help="draw at least N scenes instead of --tasks")
    parser.add_argument("--seed", type=int, default=0, help="the draw's seed (with --sample)")
    parser.add_argument("--sizes", type=lambda s: [int(x) for x in s.split(",")], default=[128, 256])
    parser.add_argument("--frames", type=int, default=20)
    parser.add_argument("--reps", type=int, default=3)
    parser.add_argument("--states", type=int, default=30)
    parser.add_argument("--generate-task", default="libero_goal/0")
    parser.add_argument("--generate-episodes", type=int, default=0, help="0: skip the generation runs")
    parser.add_argument("--generate-repeats", type=int, default=1)
    parser.add_argument("--results", type=Path, help="RESULTS.md to update")
    parser.add_argument(
        "--rows",
        type=Path,
        help="a JSON-lines file of measured rows: each scene's row is added as soon as it is measured and "
        "rows already in it are not measured again, so a run cut short goes on where it stopped (delete it "
        "to measure anew, e.g. after changing the code)",
    )
    args = parser.parse_args()
    from libero_data.pipeline.mesh_cache import build_mesh_cache
    from libero_data.tasks import get_task

    refs = sample_scenes(args.sample, args.seed) if args.sample else args.tasks.split(",")
    with tempfile.TemporaryDirectory() as cache:
        build = build_mesh_cache([get_task(r) for r in refs], cache)
        line = f"{build.meshes_built} meshes simplified, {build.meshes_found} shared with an earlier scene"
        done = _load_rows(args.rows)
        rows = []
        for size in args.sizes:
            for ref in refs:
                row = done.get((ref, size)) or measure(ref, size, args.frames, args.reps, args.states, cache)
                if args.rows is not None and (ref, size) not in done:
                    _append_row(args.rows, row)
                rows.append(row)
        generation = None
        if args.generate_episodes:
            os.environ["LIBERO_DATA_CACHE"] = cache  # the generate processes read the same cache
            generation = generation_rates(
                args.generate_task, args.generate_episodes, args.sizes[0], args.generate_repeats
            )
    text = tables(rows, args, build.seconds, line, generation)
    print(text)
    if args.results:
        from benchmarks.results import replace_section

        replace_section(args.results, "Fast rendering", text)


if __name__ == "__main__":
    main()
