"""``libero-data import``: LIBERO's HDF5 demonstrations (human) as a libero-data dataset.

Each file is one task: found in our registry from its BDDL. Each demonstration becomes the
record of one slot (:func:`~libero_data.pipeline.sources.libero_hdf5.demo_record`; that source
also says what the card says of them), written here before ``generate`` runs, after its checks:
its fixtures placed from the model XML it stores, its states stepped one action at a time under
our simulator (the largest deviation must stay within ``tolerance``), the stored init state it
began nearest to, and optionally its no-op frames dropped. ``generate`` then renders each
episode from its states (any size, cameras, naming, quality), writes its MCAP log and the card,
resumes after an interruption and runs in parallel as it does for expert episodes.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

from libero_data.errors import DatasetError, InputError
from libero_data.pipeline.episodes import search_path
from libero_data.pipeline.generate import Progress, check_output, generate
from libero_data.pipeline.request import GenerateRequest, slots_of
from libero_data.runtime.folder import DATASET_WORK, WorkFolder

if TYPE_CHECKING:
    from libero_data.hdf5.reader import LiberoFile

#: Largest one-step deviation (m or rad) of a demonstration's replay that an import accepts.
DEFAULT_TOLERANCE = 0.01


def plan_import(
    paths: list[Path],
    out: Path,
    *,
    image_size: int = 128,
    features: str = "libero-data",
    cameras: tuple[str, ...] = ("agentview", "eye_in_hand"),
    render_quality: str = "full",
    tolerance: float = DEFAULT_TOLERANCE,
    drop_noops: bool = False,
) -> tuple[GenerateRequest, dict[int, LiberoFile]]:
    """The request an import of ``paths`` (files or folders) into ``out`` makes, and each
    task's file. Files of LIBERO's tasks import as tasks of their suite; files whose BDDL is none
    of them import as tasks of their own, a suite folder in ``out`` (:func:`write_own_suite`)."""
    from libero_data.hdf5.fixtures import registry_task
    from libero_data.hdf5.reader import libero_files, read_libero_file

    if not tolerance >= 0:
        raise InputError(f"the tolerance must be a non-negative number, got {tolerance}", field="tolerance")
    files = [read_libero_file(p) for p in libero_files(paths)]
    found = [registry_task(f.bddl_content, f.bddl_file_name) for f in files]
    known = [(f, t) for f, t in zip(files, found, strict=True) if t is not None]
    if known and len(known) < len(files):
        odd = next(f for f, t in zip(files, found, strict=True) if t is None)
        raise DatasetError(
            f"{odd.path} holds a task of its own (its BDDL is none of LIBERO's 130 tasks) while {known[0][0].path} "
            f"holds {known[0][1].id}; import the files of your own tasks on their own"
        )
    by_task: dict[int, LiberoFile] = {}
    if not known:
        _own_task_names(files)  # checks the BDDL texts and names
        suite = str(Path(out).resolve())
        by_task = dict(enumerate(files))
    else:
        suite = known[0][1].suite
        for f, task in known:
            if task.suite != suite:
                raise DatasetError(
                    f"{f.path} is a {task.suite} task and the files before it {suite} tasks; import each suite's "
                    "files on their own"
                )
            if task.index in by_task:
                raise DatasetError(
                    f"{f.path} and {by_task[task.index].path} both hold demonstrations of {task.id}; import them "
                    "one at a time"
                )
            by_task[task.index] = f
    tasks = tuple(sorted(by_task))
    request = GenerateRequest(
        suite=suite,
        tasks=tasks,
        episodes_per_task=max(len(f.demo_keys) for f in by_task.values()),
        image_size=image_size,
        max_attempts=1,
        repo_id=f"libero-data/{Path(suite).name}-human",
        starts="stored",
        features=features,
        cameras=tuple(cameras),
        render_quality=render_quality,
        imported=tuple(str(by_task[i].path) for i in tasks),
        import_tolerance=float(tolerance),
        drop_noops=bool(drop_noops),
        max_length=None,  # human demonstrations are kept as long as they are; the card counts those over the limit
    )
    return request, by_task


def _own_task_names(files: list[LiberoFile]) -> list[str]:
    """The task names of files imported as tasks of their own (from LIBERO's BDDL file name),
    their embedded BDDL checked."""
    from libero_data.bddl import parse

    names = []
    for f in files:
        parse(f.bddl_content, source=f"{f.path} (its embedded BDDL)")
        stem = f.bddl_file_name.replace("\\", "/").rsplit("/", 1)[-1].removesuffix(".bddl") or f.path.stem
        names.append(stem)
    if len(set(names)) != len(names):
        twice = next(n for n in names if names.count(n) > 1)
        raise DatasetError(
            f"two files hold demonstrations of a task named {twice}; import them one at a time"
        )
    return names


def write_own_suite(out: Path, files: list[LiberoFile]) -> None:
    """The suite folder of files imported as tasks of their own: ``out/suite.json`` and each
    file's embedded BDDL in ``out/tasks/`` (as ``generate --procedural`` writes a suite)."""
    import json

    from libero_data.runtime.files import write_text
    from libero_data.tasks import SUITE_MANIFEST

    names = _own_task_names(files)
    entries = []
    for name, f in zip(names, files, strict=True):
        write_text(out / "tasks" / f"{name}.bddl", f.bddl_content)
        entries.append({"name": name, "language": f.language or None, "bddl": f"tasks/{name}.bddl"})
    write_text(
        out / SUITE_MANIFEST, json.dumps({"name": out.name, "imported": True, "tasks": entries}, indent=1)
    )


def import_records(
    request: GenerateRequest,
    by_task: dict[int, LiberoFile],
    folder: Path,
    *,
    on_step: Callable[[str], None] | None = None,
) -> None:
    """Write the search record of every slot not written yet (one demonstration each)."""
    from libero_data.pipeline.sources.libero_hdf5 import demo_record
    from libero_data.sim import EnvConfig, LiberoEnv
    from libero_data.tasks import get_suite

    suite = get_suite(request.suite)
    slots = slots_of(request)
    for position, index in enumerate(request.tasks):
        todo = [s for s in slots if s.position == position and not (folder / search_path(s.key)).is_file()]
        if not todo:
            continue
        task, source = suite.task(index), by_task[index]
        with LiberoEnv(task, EnvConfig(cameras=())) as env:
            stored = task.init_states() if task.init_states_path is not None else None
            for slot in todo:
                if on_step:
                    on_step(f"checking {task.id} demonstration {slot.k + 1}/{len(source.demo_keys)}")
                demo_record(env, task.id, request, source, slot, stored).save(folder / search_path(slot.key))


def import_hdf5(
    paths: list[Path],
    out: str | Path,
    *,
    image_size: int = 128,
    features: str = "libero-data",
    cameras: tuple[str, ...] = ("agentview", "eye_in_hand"),
    render_quality: str = "full",
    tolerance: float = DEFAULT_TOLERANCE,
    drop_noops: bool = False,
    workers: int = 1,
    executor: str = "local",
    ray_address: str | None = None,
    on_progress: Callable[[Progress], None] | None = None,
    on_step: Callable[[str], None] | None = None,
    command: str = "",
    keep_work: bool = False,
) -> Progress:
    """Import LIBERO's HDF5 demonstrations into the dataset ``out`` (resumes an interrupted run)."""
    out = Path(out).resolve()
    request, by_task = plan_import(
        [Path(p) for p in paths],
        out,
        image_size=image_size,
        features=features,
        cameras=cameras,
        render_quality=render_quality,
        tolerance=tolerance,
        drop_noops=drop_noops,
    )
    return run_import(
        request,
        by_task,
        out,
        workers=workers,
        executor=executor,
        ray_address=ray_address,
        on_progress=on_progress,
        on_step=on_step,
        command=command,
        keep_work=keep_work,
    )


def run_import(
    request: GenerateRequest,
    by_task: dict[int, LiberoFile],
    out: Path,
    *,
    workers: int = 1,
    executor: str = "local",
    ray_address: str | None = None,
    on_progress: Callable[[Progress], None] | None = None,
    on_step: Callable[[str], None] | None = None,
    command: str = "",
    keep_work: bool = False,
) -> Progress:
    """Carry out a planned import (:func:`plan_import`) into ``out``: the checked records, then
    ``generate`` renders and publishes them."""
    out = Path(out).resolve()
    if check_output(request, out) is None:  # not finished before (and nothing else in ``out``)
        if request.suite == str(out):
            out.mkdir(parents=True, exist_ok=True)
            write_own_suite(out, [by_task[i] for i in request.tasks])
        folder = WorkFolder(out / DATASET_WORK, "dataset")
        with folder.locked(owner=out):
            folder.claim(request.to_dict(), name="request.json", owner=out, upgrade=GenerateRequest.upgrade)
            import_records(request, by_task, folder.root, on_step=on_step)
    return generate(
        request,
        out,
        workers=workers,
        executor=executor,
        ray_address=ray_address,
        on_progress=on_progress,
        command=command,
        keep_work=keep_work,
    )
