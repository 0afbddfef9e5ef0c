"""The codec of rollout videos: H.264 (the rollouts') against LeRobot's AV1 (the demonstrations').

One rollout's frames as the standard protocol stores them: ``--task`` at 256 px, both cameras,
``--steps`` steps of small random actions, images drawn every 5th step and held between (a client
executing 5 actions of each chunk). Each codec encodes the two cameras as a rollout is written
(:class:`libero_data.record.encoder.EpisodeVideoEncoder`, one thread per camera), ``--repeats``
times; reported: CPU seconds (the process's, both threads), wall seconds, file size, PSNR of the
decoded frames against the drawn ones, and the time to read a frame at random. The settings are the
ones used: LeRobot's defaults for AV1 (demonstrations), H.264 with a key frame every 2 frames (the
rollouts' before), and :data:`libero_bench.rollouts.episodes.ROLLOUT_VIDEO` with key frames at new
images (``ROLLOUT_KEY_SPACING``, the rollouts' now).

    python -m benchmarks.bench_rollout_codec --results
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

os.environ.setdefault("OMP_NUM_THREADS", "1")

ROOT = Path(__file__).resolve().parents[1]
CAMERAS = ("agentview", "eye_in_hand")


def rollout_frames(task: str, steps: int, seed: int = 0) -> list[dict[str, np.ndarray]]:
    """The two cameras' images of a rollout, drawn every 5th step and held between."""
    from libero_data.sim import EnvConfig, LiberoEnv

    env = LiberoEnv(task, EnvConfig(image_size=256, cameras=CAMERAS))
    obs = env.reset(seed=seed, settle=10)
    rng = np.random.default_rng(seed)
    frames = []
    for t in range(steps):
        frames.append({c: obs[c] for c in CAMERAS})
        before = obs
        obs, _ok = env.step(rng.uniform(-0.3, 0.3, 7), render=t % 5 == 4)
        for camera in CAMERAS:
            obs.setdefault(camera, before[camera])
    env.close()
    return frames


def psnr(path: Path, frames: list[np.ndarray]) -> float:
    import av

    errors = []
    with av.open(str(path)) as container:
        for i, picture in enumerate(container.decode(video=0)):
            decoded = picture.to_ndarray(format="rgb24").astype(np.float64)
            errors.append(((decoded - frames[i]) ** 2).mean())
    if len(errors) != len(frames):
        raise RuntimeError(f"{path.name}: {len(errors)} frames decoded, {len(frames)} written")
    return float(10 * np.log10(255**2 / np.mean(errors)))


def random_reads(path: Path, count: int, seed: int = 0) -> float:
    """Mean seconds to decode one frame picked at random, as a loader does: seek to the key frame
    at or before it, decode forward to it."""
    import av

    with av.open(str(path)) as container:
        stream = container.streams.video[0]
        total, base = stream.frames, stream.time_base
        assert base is not None
        picks = np.random.default_rng(seed).integers(0, total, count)
        started = time.perf_counter()
        for index in picks:
            target = int(index) / 20
            container.seek(int(target / base), stream=stream, backward=True, any_frame=False)
            for picture in container.decode(stream):
                if picture.time is not None and picture.time >= target - 1e-6:
                    break
    return (time.perf_counter() - started) / count


def encode(
    config: Any, frames: list[dict[str, np.ndarray]], work: Path, key_spacing: int | None
) -> dict[str, Any]:
    from libero_data.record.encoder import EpisodeVideoEncoder

    encoder = EpisodeVideoEncoder(20, config, key_spacing=key_spacing)
    wall, cpu = time.perf_counter(), time.process_time()
    encoder.start_episode(list(CAMERAS), work)
    for frame in frames:
        for camera in CAMERAS:
            encoder.feed_frame(camera, frame[camera])
    written = encoder.finish_episode()
    out: dict[str, Any] = {"wall_s": time.perf_counter() - wall, "cpu_s": time.process_time() - cpu}
    out["mb"] = sum(p.stat().st_size for p, _stats in written.values()) / 1e6
    out["psnr"] = {c: psnr(written[c][0], [f[c] for f in frames]) for c in CAMERAS}
    out["read_ms"] = 1000 * float(np.mean([random_reads(written[c][0], 40) for c in CAMERAS]))
    return out


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--task", default="libero_object/0")
    parser.add_argument(
        "--steps", type=int, default=290, help="Frames of the rollout (280 steps + 10 waits)."
    )
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument(
        "--results", action="store_true", help="Replace this benchmark's section of RESULTS.md."
    )
    args = parser.parse_args()

    from lerobot.configs.video import RGBEncoderConfig
    from lerobot.datasets.video_utils import rgb_encoder_defaults

    from libero_bench.rollouts.episodes import ROLLOUT_KEY_SPACING, ROLLOUT_VIDEO

    frames = rollout_frames(args.task, args.steps)
    codecs = {
        "AV1 (LeRobot's defaults: demonstrations)": (rgb_encoder_defaults(), None),
        "H.264, a key frame every 2 frames (rollouts before)": (
            RGBEncoderConfig(**{**ROLLOUT_VIDEO, "g": 2}),
            None,
        ),
        "H.264, key frames at new images (rollouts)": (
            RGBEncoderConfig(**ROLLOUT_VIDEO),
            ROLLOUT_KEY_SPACING,
        ),
    }
    rows = []
    with tempfile.TemporaryDirectory(prefix="bench-codec-") as tmp:
        for name, (config, spacing) in codecs.items():
            runs = [encode(config, frames, Path(tmp), spacing) for _ in range(args.repeats)]
            best = min(runs, key=lambda r: r["cpu_s"])
            settings = ", ".join(f"{k} {v}" for k, v in config.get_codec_options(1, as_strings=True).items())
            if spacing is not None:
                settings += f"; a key frame at each new image {spacing}+ frames after the last"
            rows.append((name, f"{config.vcodec}: {settings}", best))
            print(name, best, flush=True)
    base = rows[0][2]["cpu_s"]
    lines = [
        f"Run: `python -m benchmarks.bench_rollout_codec --results` ({args.task}, 256 px, both cameras, "
        f"{args.steps} frames with the images drawn every 5th step and held between, as the standard "
        f"protocol stores a rollout; best of {args.repeats} by CPU time).",
        "",
        "| codec | settings | CPU s | wall s | MB | PSNR agentview | PSNR eye_in_hand | random frame read, ms "
        "| CPU against AV1 |",
        "|---|---|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for name, settings, r in rows:
        lines.append(
            f"| {name} | {settings} | {r['cpu_s']:.2f} | {r['wall_s']:.2f} | {r['mb']:.2f} | "
            f"{r['psnr']['agentview']:.1f} dB | {r['psnr']['eye_in_hand']:.1f} dB | {r['read_ms']:.1f} | "
            f"{r['cpu_s'] / base:.2f}× |"
        )
    lines += [
        "",
        "Random frame read: the mean time to decode one frame picked at random (40 per camera), seeking to "
        "the key frame before it and decoding forward, as a training loader does. With a new image every "
        "step (a policy acting every step) the key frames at new images fall every 2 frames, LeRobot's `g`.",
    ]
    body = "\n".join(lines) + "\n"
    print(body)
    if args.results:
        from benchmarks.results import replace_section

        replace_section(ROOT / "benchmarks" / "RESULTS.md", "Rollout videos: H.264 against AV1", body)


if __name__ == "__main__":
    main()
