"""A rollout's stored images are the policy's view: drawn where it looked and held between, so
frames share one image array. The logs compress a held image once and still give every frame its
own message with the right picture."""

from __future__ import annotations

import base64
import io
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from libero_data.record.mcap_log import read_mcap, write_episode_mcap


def held_frames(size: int = 32) -> list[dict[str, Any]]:
    """Six frames: the first three hold one pair of images, the last three have their own."""
    ramp = np.add.outer(np.arange(size), np.arange(size)) * (200 // (2 * size))  # smooth: JPEG keeps it
    held = {c: np.repeat(ramp[..., None], 3, axis=2).astype(np.uint8) for c in ("agentview", "eye_in_hand")}
    frames = []
    for t in range(6):
        images = held if t < 3 else {c: np.full((size, size, 3), 40 * t, np.uint8) for c in held}
        frames.append(
            {
                **images,
                "state": np.zeros(8, np.float32),
                "joint_pos": np.zeros(7, np.float32),
                "gripper_state": np.zeros(2, np.float32),
                "eef_pos": np.zeros(3),
                "eef_quat": np.array([0.0, 0.0, 0.0, 1.0]),
                "action": np.full(7, t, np.float32),
            }
        )
    return frames


def decoded(data: bytes) -> np.ndarray:
    from PIL import Image

    return np.asarray(Image.open(io.BytesIO(data)).convert("RGB"))


def test_mcap_gives_every_frame_its_own_picture_of_a_held_image(tmp_path: Path) -> None:
    frames = held_frames()
    path = write_episode_mcap(
        tmp_path / "e.mcap", frames=frames, task="t", instruction="i", success=[False] * 6
    )
    pictures = [m["data"] for topic, _t, m in read_mcap(path) if topic == "/camera/agentview"]
    assert len(pictures) == 6
    assert pictures[0] == pictures[1] == pictures[2] and len(set(pictures[2:])) == 4
    for frame, data in zip(frames, pictures, strict=True):
        error = np.abs(decoded(base64.b64decode(data)).astype(int) - frame["agentview"].astype(int))
        assert error.mean() < 3  # JPEG at quality 90 of this frame's image, not another's


@pytest.mark.filterwarnings("ignore::DeprecationWarning")
def test_rerun_gives_every_frame_its_own_picture_of_a_held_image(tmp_path: Path) -> None:
    import rerun.recording as rd

    from libero_bench.rollouts.rerun_log import write_rollout_rrd

    frames = held_frames()
    out = tmp_path / "r.rrd"
    write_rollout_rrd(out, frames=frames, success=[False] * 6, language="i", tags={}, recording_id="r")
    table = rd.load_recording(str(out)).view(index="step", contents="/**").select().read_all()
    column = table.column("/cameras/agentview:EncodedImage:blob").to_pylist()
    blobs = [bytes(np.asarray(cell[0], np.uint8)) for cell in column]
    assert len(blobs) == 6
    assert blobs[0] == blobs[1] == blobs[2] and len(set(blobs[2:])) == 4
    for frame, data in zip(frames, blobs, strict=True):
        assert np.abs(decoded(data).astype(int) - frame["agentview"].astype(int)).mean() < 3


@pytest.mark.filterwarnings("ignore::DeprecationWarning")
def test_rerun_scalars_are_the_frames_values_step_for_step(tmp_path: Path) -> None:
    # The scalars go in as columns: each step's row still holds that step's values.
    import rerun.recording as rd

    from libero_bench.rollouts.rerun_log import write_rollout_rrd

    frames = held_frames()
    for t, frame in enumerate(frames):
        frame["state"] = np.arange(8, dtype=np.float32) + 10 * t
        frame["joint_pos"] = -np.arange(7, dtype=np.float32) - t
    success = [False] * 5 + [True]
    out = tmp_path / "r.rrd"
    write_rollout_rrd(out, frames=frames, success=success, language="i", tags={}, recording_id="r")
    table = rd.load_recording(str(out)).view(index="step", contents="/**").select().read_all()

    def series(entity: str) -> list[float]:
        return [cell[0] for cell in table.column(f"/{entity}:Scalars:scalars").to_pylist()]

    assert table.column("step").to_pylist() == list(range(6))
    assert series("state/eef_x") == [10.0 * t for t in range(6)]
    assert series("state/gripper_right") == [7.0 + 10 * t for t in range(6)]
    assert series("joints/joint_3") == [-2.0 - t for t in range(6)]
    assert series("action/gripper") == [float(t) for t in range(6)]
    assert series("success") == [0.0] * 5 + [1.0]
    times = table.column("time").to_pylist()
    assert [t.total_seconds() for t in times] == pytest.approx([t / 20 for t in range(6)])
