"""``libero-data rerender``: a dataset's episodes rendered again at another image size, camera
set or feature naming, from the MuJoCo states it stores.

The same episodes, in the same order, with the same actions and states: each episode of the
source becomes the search record of its slot in a new dataset folder (no expert runs), and
``generate`` renders and publishes them as it does any searched episode. So one expert run
serves 128x128 and 256x256 users alike, and the new folder resumes like any other.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np

from libero_data.errors import DatasetError
from libero_data.pipeline.episodes import search_path
from libero_data.pipeline.generate import Progress, check_output, generate
from libero_data.pipeline.request import GenerateRequest, Slot, slots_of
from libero_data.pipeline.resimulate import recorded_machines, stored_episode
from libero_data.pipeline.sources import EpisodeRecord
from libero_data.pipeline.validate import episode_table
from libero_data.runtime.files import read_json, read_json_lines
from libero_data.runtime.folder import DATASET_WORK, WorkFolder

#: What a slot the source gave up on says in the new dataset.
GIVEN_UP = "given up when the source dataset was made"


def rerender_request(
    source: Path, *, image_size: int, features: str, cameras: tuple[str, ...], render_quality: str = "full"
) -> GenerateRequest:
    """The source dataset's request with the new rendering settings."""
    from libero_data.pipeline.readable import readable_dataset

    meta_path = source / "meta" / "libero.json"
    readable_dataset(source)
    if not meta_path.is_file():
        raise DatasetError(f"{source} is not a libero-data dataset (meta/libero.json is missing)")
    saved = read_json(meta_path, required=("request",))
    if not saved.get("complete"):
        raise DatasetError(
            f"{source} is not complete yet; finish generating it first (run its command again)"
        )
    request = GenerateRequest.from_dict(saved["request"])
    return request.replace(
        image_size=image_size,
        features=features,
        cameras=tuple(cameras),
        rerender_of=str(source.resolve()),
        render_quality=render_quality,
    )


def _records(source: Path, request: GenerateRequest) -> dict[str, EpisodeRecord]:
    """The search record of every slot, from the source's episodes (slot by slot)."""
    info = read_json(source / "meta" / "info.json")
    rows = read_json_lines(source / "meta" / "libero_episodes.jsonl")
    machines = recorded_machines(source)
    episodes = {int(e["episode_index"]): e for e in episode_table(source)}
    slots = slots_of(request)
    taken: dict[int, int] = {}  # position -> slots used, for datasets that did not record their slots
    records: dict[str, EpisodeRecord] = {}
    for row in rows:
        position = request.tasks.index(int(row["task_index"]))
        key = row.get("slot") or Slot(position, int(row["task_index"]), taken.get(position, 0)).key
        taken[position] = int(key.split("-")[1]) + 1
        actions, states = stored_episode(source, info, episodes[int(row["episode_index"])])
        machine = machines.get(
            str(row.get("numeric_key")), {"numeric_key": row.get("numeric_key", "unknown")}
        )
        records[key] = EpisodeRecord(
            success=True,
            attempts=int(row.get("attempt", 0)) + 1,
            code=row.get("expert_code", "unknown"),
            machine=machine,
            init_index=int(row["init_index"]),
            reset_seed=int(row["reset_seed"]),
            expert_seed=int(row["expert_seed"]),
            actions=np.asarray(actions, dtype=np.float64),
            states=np.asarray(states, dtype=np.float64),
            plan=tuple(row.get("plan", [])),
            goal_step=int(row.get("goal_step", 0)),  # its steps after the goal are rendered too
        )
    for slot in slots:
        records.setdefault(
            slot.key,
            EpisodeRecord(success=False, attempts=request.max_attempts, failures=(GIVEN_UP,), code=""),
        )
    return records


def rerender(
    source: str | Path,
    out: str | Path,
    *,
    image_size: int,
    features: str = "libero-data",
    cameras: tuple[str, ...] = ("agentview", "eye_in_hand"),
    render_quality: str = "full",
    workers: int = 1,
    on_progress: Callable[[Progress], None] | None = None,
    command: str = "",
    keep_work: bool = False,
) -> Progress:
    """Render the episodes of ``source`` again into ``out`` (resumes an interrupted run)."""
    source, out = Path(source).resolve(), Path(out).resolve()
    request = rerender_request(
        source, image_size=image_size, features=features, cameras=cameras, render_quality=render_quality
    )
    check_rerender_output(source, out, request)
    folder = WorkFolder(out / DATASET_WORK, "dataset")
    if not (out / "meta" / "libero.json").is_file():  # not finished before
        with folder.locked(owner=out):
            folder.claim(request.to_dict(), name="request.json", owner=out, upgrade=GenerateRequest.upgrade)
            for key, record in _records(source, request).items():
                path = folder.root / search_path(key)
                if not path.is_file():
                    record.save(path)
    return generate(
        request, out, workers=workers, on_progress=on_progress, command=command, keep_work=keep_work
    )


def check_rerender_output(source: Path, out: Path, request: GenerateRequest) -> None:
    """What would refuse re-rendering ``source`` into ``out``, checked without writing."""
    if Path(source).resolve() == Path(out).resolve():
        raise DatasetError(f"{out} is the source dataset; choose another output folder")
    check_output(request, out)
