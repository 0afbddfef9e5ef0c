"""A libero-data dataset as training data: its tasks, episodes and decoded frames.

A :class:`DemoDataset` is the dataset on disk (read through lerobot: metadata, the parquet
columns and the per-episode videos) with its task list and which episodes belong to which
task; :meth:`DemoDataset.load_episode` decodes one episode's two videos as a whole into
uint8 tensors (``N, 3, H, W``). :mod:`libero_bench.data.windows` turns episodes into training
windows and batches.

Memory per 1,000 decoded frames (two cameras, ``2 * 3 * H * W`` bytes per frame): ~98 MB at
128x128, ~25 MB at 64x64 (low-dimensional columns add ~64 kB). A LIBERO-10 task (50
demonstrations of ~300 frames) is ~1.5 GB at 128x128; training on all of LIBERO-90 at once
(MTL) would need ~66 GB.

DataLoader workers: ``WindowDataset.preload`` decodes everything in the calling process;
workers then share the cache (fork, copy-on-write) and never decode. ``worker_init`` sets one
thread per worker and clears lerobot's module-level video decoder cache, whose open file
handles do not survive a fork. With ``multiprocessing_context="spawn"`` the cache is pickled
into every worker instead.
"""

from __future__ import annotations

import logging
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, NamedTuple

import numpy as np

from libero_bench.data.batch_keys import (
    ACTIONS,
    AGENTVIEW,
    GRIPPER_STATES,
    JOINT_STATES,
    WRIST,
)
from libero_data.errors import DatasetError, InputError
from libero_data.record.features import ACTION, GRIPPER, JOINTS, StoredColumns, camera_keys_of
from libero_data.runtime.files import read_json, read_json_lines

if TYPE_CHECKING:
    import torch

logger = logging.getLogger(__name__)

#: The low-dimensional inputs and targets -> their columns (a dataset made before the ``libero.*``
#: columns keeps the joints and the gripper under ``observation.*``: :class:`StoredColumns`).
LOWDIM_FEATURES = {JOINT_STATES: JOINTS, GRIPPER_STATES: GRIPPER, ACTIONS: ACTION}
REQUIRED_FEATURES = (JOINTS, GRIPPER, ACTION)
#: the policies' camera inputs -> our camera names
CAMERA_INPUTS = {AGENTVIEW: "agentview", WRIST: "eye_in_hand"}


@dataclass(frozen=True)
class DemoTask:
    """One task of a dataset: its name, instruction, suite and episodes (dataset indices)."""

    name: str
    language: str
    suite: str
    suite_index: int | None
    episodes: tuple[int, ...]


class EpisodeFrames(NamedTuple):
    """One decoded episode: uint8 images (N, 3, H, W) and float32 low-dim arrays (N, D)."""

    agentview: torch.Tensor
    wrist: torch.Tensor
    joint_states: np.ndarray
    gripper_states: np.ndarray
    actions: np.ndarray

    def __len__(self) -> int:
        return int(self.actions.shape[0])


class DemoDataset:
    """A libero-data (LeRobot v3) dataset on disk: tasks, episodes and decoded frames.

    Raises ``ValueError`` (one sentence naming the folder or feature) when ``root`` is not a
    LeRobot dataset or lacks a feature the policies need.
    """

    def __init__(self, root: str | Path) -> None:
        from libero_data.pipeline.readable import readable_dataset

        self.root = Path(root)
        self.info: dict[str, Any] = readable_dataset(self.root)
        features = self.info["features"]
        cameras = camera_keys_of(features)  # either naming profile
        missing = [f"the {c} camera" for c in CAMERA_INPUTS.values() if c not in cameras]
        #: Each required feature's column in this dataset.
        stored = StoredColumns.of(features)
        self.columns = {JOINTS: stored.joints, GRIPPER: stored.gripper, ACTION: ACTION}
        missing += [f for f, column in self.columns.items() if column not in features]
        if missing:
            raise DatasetError(
                f"{self.root} lacks the feature(s) {', '.join(missing)} that the policies need"
            )
        self.camera_features = {name: cameras[camera] for name, camera in CAMERA_INPUTS.items()}
        for key in self.camera_features.values():
            if features[key].get("dtype") != "video":
                raise DatasetError(f"{self.root}: feature {key} must be stored as video")
            videos = self.root / "videos" / key
            if not (videos.is_dir() and any(videos.rglob("*.mp4"))):
                raise DatasetError(
                    f"{videos} is missing or holds no videos: {self.root} is not a whole dataset"
                )
        shape = features[self.camera_features[AGENTVIEW]]["shape"]
        self.image_size = int(shape[0])
        self.fps = float(self.info["fps"])
        meta_path = self.root / "meta" / "libero.json"
        self.libero_meta: dict[str, Any] = read_json(meta_path) if meta_path.is_file() else {}
        request = self.libero_meta.get("request", {})
        self.repo_id = str(request.get("repo_id") or f"local/{self.root.name}")
        self.suite = str(request.get("suite") or self.libero_meta.get("suite") or "")
        sim_feature = features.get(stored.sim_state, {})
        self.sim_state_width = int(
            self.libero_meta.get("sim_state_width") or (sim_feature.get("shape") or [0])[0]
        )
        self._lerobot: Any = None
        self._columns: dict[str, np.ndarray] | None = None
        self.decode_count = 0  # episodes decoded by this object (in this process)
        self.episode_meta = self._read_episode_meta()
        self.tasks = self._read_tasks()

    # -- metadata -------------------------------------------------------------------------------
    @property
    def lerobot(self) -> Any:
        """lerobot's ``LeRobotDataset`` over the folder (opened on first use)."""
        if self._lerobot is None:
            from lerobot.datasets.lerobot_dataset import LeRobotDataset

            self._lerobot = LeRobotDataset(self.repo_id, root=self.root, download_videos=False)
        return self._lerobot

    def _read_episode_meta(self) -> list[dict[str, Any]]:
        path = self.root / "meta" / "libero_episodes.jsonl"
        total = int(self.info.get("total_episodes", 0))
        if path.is_file():
            rows = read_json_lines(path)
            by_index = {int(r.get("episode_index", i)): r for i, r in enumerate(rows)}
            if sorted(by_index) == list(range(total)):
                return [by_index[i] for i in range(total)]
            logger.warning("%s: meta/libero_episodes.jsonl does not cover every episode; ignoring it", path)
        # a plain LeRobot dataset: the task of an episode is its language instruction
        episodes = self.lerobot.meta.episodes
        return [
            {
                "episode_index": int(e["episode_index"]),
                "language": str(e["tasks"][0]),
                "length": int(e["length"]),
            }
            for e in episodes
        ]

    def _read_tasks(self) -> list[DemoTask]:
        by_task: dict[str, list[int]] = {}
        languages: dict[str, str] = {}
        for i, row in enumerate(self.episode_meta):
            name = str(row.get("task_name") or row.get("language"))
            by_task.setdefault(name, []).append(i)
            languages.setdefault(name, str(row.get("language") or name))
        listed = self.libero_meta.get("tasks") or []
        tasks: list[DemoTask] = []
        for entry in listed:
            name = str(entry["name"])
            if name in by_task:
                index = entry.get("index")
                tasks.append(
                    DemoTask(
                        name=name,
                        language=str(entry.get("language") or languages[name]),
                        suite=self.suite,
                        suite_index=int(index) if index is not None else None,
                        episodes=tuple(by_task.pop(name)),
                    )
                )
        for name, episodes in by_task.items():  # tasks the metadata does not list, in episode order
            tasks.append(DemoTask(name, languages[name], self.suite, None, tuple(episodes)))
        if not tasks:
            raise DatasetError(f"{self.root} holds no episodes")
        return tasks

    def training_starts(self, task: DemoTask) -> tuple[set[int], set[int]] | None:
        """Where the task's demonstrations started: the stored init state indices and the
        sampler reset seeds; None for a dataset that does not record it (not made by libero-data)."""
        return self.starts_of(task.episodes)

    def starts_of(self, episodes: Iterable[int]) -> tuple[set[int], set[int]] | None:
        """Where these episodes started (as :meth:`training_starts`); None where one of them
        does not record it."""
        stored: set[int] = set()
        seeds: set[int] = set()
        for i in episodes:
            row = self.episode_meta[i]
            if "init_index" not in row:
                return None
            if int(row["init_index"]) >= 0:
                stored.add(int(row["init_index"]))
            elif "reset_seed" in row:
                seeds.add(int(row["reset_seed"]))
        return stored, seeds

    def task(self, ref: str | int) -> DemoTask:
        """A task by name, or by its index in the suite (as ``libero-data generate --tasks``)."""
        key = str(ref).strip()
        for t in self.tasks:
            if t.name == key:
                return t
        if key.lstrip("-").isdigit():
            i = int(key)
            by_suite = [t for t in self.tasks if t.suite_index == i]
            if by_suite:
                return by_suite[0]
            if all(t.suite_index is None for t in self.tasks) and 0 <= i < len(self.tasks):
                return self.tasks[i]
        known = ", ".join(
            f"{t.suite_index}:{t.name}" if t.suite_index is not None else t.name for t in self.tasks
        )
        raise InputError(f"{self.root} has no task {key!r}; it has {known}", field="tasks")

    def bddl_text(self, task: DemoTask) -> str | None:
        """The task's BDDL as stored with the dataset (``meta/bddl/<name>.bddl``), if any."""
        path = self.root / "meta" / "bddl" / f"{task.name}.bddl"
        return path.read_text() if path.is_file() else None

    def episode_length(self, episode: int) -> int:
        row = self.episode_meta[episode]
        if "length" in row:
            return int(row["length"])
        return int(self.lerobot.meta.episodes[episode]["length"])

    # -- frames ---------------------------------------------------------------------------------
    def _table(self) -> dict[str, np.ndarray]:
        if self._columns is None:
            hf = self.lerobot.hf_dataset.with_format("numpy")
            stored = {f: self.columns[f] for f in LOWDIM_FEATURES.values()}
            table = hf.select_columns(["episode_index", "timestamp", *stored.values()])[:]
            self._columns = {c: np.asarray(table[c]) for c in ("episode_index", "timestamp")}
            self._columns.update({f: np.asarray(table[column]) for f, column in stored.items()})
        return self._columns

    def load_episode(self, episode: int, image_size: int | None = None) -> EpisodeFrames:
        """Decode one episode (both videos in one pass each); images resized to ``image_size``."""
        from lerobot.datasets.video_utils import decode_video_frames

        if not 0 <= episode < len(self.episode_meta):
            raise InputError(
                f"{self.root} has episodes 0..{len(self.episode_meta) - 1}, not {episode}", field="episode"
            )
        table = self._table()
        rows = np.flatnonzero(table["episode_index"] == episode)
        timestamps = table["timestamp"][rows].astype(np.float64)
        meta = self.lerobot.meta
        record = meta.episodes[episode]
        images: dict[str, torch.Tensor] = {}
        for key, feature in self.camera_features.items():
            start = float(record[f"videos/{feature}/from_timestamp"])
            path = self.root / meta.get_video_file_path(episode, feature)
            frames = decode_video_frames(
                path,
                [start + float(t) for t in timestamps],
                self.lerobot.tolerance_s,
                self.lerobot._video_backend,
                return_uint8=True,
            )
            images[key] = _resize(frames, image_size) if image_size else frames
        self.decode_count += 1
        return EpisodeFrames(
            agentview=images[AGENTVIEW].contiguous(),
            wrist=images[WRIST].contiguous(),
            joint_states=table[JOINTS][rows].astype(np.float32),
            gripper_states=table[GRIPPER][rows].astype(np.float32),
            actions=table[ACTION][rows].astype(np.float32),
        )

    def __getstate__(self) -> dict[str, Any]:
        # lerobot's dataset object holds open readers; a worker reopens it when needed
        state = dict(self.__dict__)
        state["_lerobot"] = None
        return state


def _resize(frames: torch.Tensor, size: int) -> torch.Tensor:
    import torch
    import torch.nn.functional as F

    if frames.shape[-1] == size and frames.shape[-2] == size:
        return frames
    out = F.interpolate(
        frames.float(), size=(size, size), mode="bilinear", antialias=True, align_corners=False
    )
    return out.round().clamp(0, 255).to(torch.uint8)
