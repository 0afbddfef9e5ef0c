"""Carry lifelong runs in progress to another machine without their data (issue 59): the runs of
``benchmarks/lifelong.sh`` outlast a session, and a session's machine may keep nothing but the
repository.

    python -m benchmarks.lifelong_carry out WORK CARRY   # each unfinished run of WORK/runs -> CARRY/<run>/
        [--also RUN ...]                                 # and finished ones still to be evaluated
    python -m benchmarks.lifelong_carry in CARRY WORK    # back into WORK/runs (and the data, where WORK has none)
    python -m benchmarks.lifelong_carry diff CARRY DATA  # a dataset made again here against the carried one

What is carried of a run: its JSON files and log, the newest task checkpoint and the state of the
task in progress (ER's without its memory's windows, which the run rebuilds from the data:
``libero_bench.algos.er``). Not carried: older checkpoints, and the recordings of the rollouts made
so far (0.8 MB of shard and 0.8 MB of Rerun recording each: 200 MB a run); their outcomes are in
``results.json``, and the run's joined rollout dataset names them as left behind
(``RUN/.work/left_behind.json``).

The datasets the unfinished runs learn from are carried too (``CARRY/datasets/<name>/``: card,
``meta/``, ``data/``, ``videos/``; not the MCAP logs; a finished run, carried to be evaluated, needs
only its checkpoint), because making them again does not give the same bytes
on another machine: the 300 episodes of libero_object 0, 1, 2 made on an Intel Xeon and again on an
AMD EPYC, same command, seed and code, had other digests (each machine made the same bytes twice).
Git stores a file's bytes once, so the dataset costs the history its size (~100 MB at 64x64) once,
not at each carry. ``in`` puts a carried dataset where its runs look for it when nothing is there;
``carry.json`` records each file's SHA-256 and a digest of each dataset's frames and tables, and
``in`` refuses a dataset whose digest differs, since the run would go on from other demonstrations.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import re
import shutil
from collections.abc import Sequence
from pathlib import Path
from typing import Any

FORMAT = "libero-bench-carry/1"
#: a run's top-level files that are carried when present
TOP_FILES = ("config.json", "results.json", "timings.jsonl", "run.log", "training_data.json")
#: what of a dataset is carried: what training reads (its MCAP logs are not)
DATASET_PARTS = ("README.md", "meta", "data", "videos")


def sha256(path: Path) -> str:
    digest = hashlib.sha256()
    with path.open("rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def data_digest(dataset: Path) -> str:
    """A digest of a LeRobot dataset's tables and videos (``data/``, ``videos/``): names and bytes."""
    digest = hashlib.sha256()
    files = sorted(p for part in ("data", "videos") for p in (dataset / part).rglob("*") if p.is_file())
    if not files:
        raise SystemExit(f"{dataset} holds no data/ or videos/ files: is it a dataset?")
    for path in files:
        digest.update(f"{path.relative_to(dataset).as_posix()}\0{sha256(path)}\n".encode())
    return digest.hexdigest()


def run_datasets(run: Path) -> list[Path]:
    """The datasets a run's ``config.json`` names (relative to the run folder)."""
    from libero_bench.runs.training_data import resolve

    config = json.loads((run / "config.json").read_text())
    mixed = [d["data"] for d in config.get("mix", {}).get("datasets", [])]  # mixing's config entry
    return [resolve(run, name).resolve() for name in [config["data"], *mixed]]


def dataset_files(dataset: Path) -> list[Path]:
    """The files of ``dataset`` that are carried (relative to it)."""
    files = []
    for part in DATASET_PARTS:
        path = dataset / part
        if path.is_file():
            files.append(Path(part))
        elif path.is_dir():
            files.extend(p.relative_to(dataset) for p in sorted(path.rglob("*")) if p.is_file())
    return files


def pack_dataset(dataset: Path, target: Path) -> dict[str, str]:
    """Copy the carried files of ``dataset`` into ``target``; returns their SHA-256 by path."""
    files: dict[str, str] = {}
    for rel in dataset_files(dataset):
        (target / rel).parent.mkdir(parents=True, exist_ok=True)
        if rel == Path("README.md"):  # the card names the folder it was made in: name it by itself
            card = (dataset / rel).read_text()
            (target / rel).write_text(card.replace(str(dataset.resolve()), dataset.name))
        else:
            shutil.copy2(dataset / rel, target / rel)
        files[rel.as_posix()] = sha256(target / rel)
    return files


def unpack_dataset(source: Path, files: dict[str, str], dataset: Path) -> None:
    """Put a carried dataset at ``dataset`` (which must not exist), checking every file; nothing is
    left there when a file differs from what carry.json records."""
    staging = dataset.with_name(f".{dataset.name}.carry")
    shutil.rmtree(staging, ignore_errors=True)
    try:
        for rel, digest in files.items():
            (staging / rel).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(source / rel, staging / rel)
            if sha256(staging / rel) != digest:
                raise SystemExit(f"{source / rel} differs from what carry.json records")
    except BaseException:
        shutil.rmtree(staging, ignore_errors=True)
        raise
    staging.rename(dataset)


def portable_copy(source: Path, target: Path, work: Path, moves: Sequence[tuple[Path, Path]] = ()) -> None:
    """Copy a text file of ``work`` (an evaluation's JSON or report) to ``target``, naming the paths
    of ``work`` relative to the file's folder there (they resolve again once carried back) and the
    installed packages' files from their package (``libero/libero/bddl_files/...``), not by this
    machine's absolute paths.

    ``moves`` are (old, new) folders for a target laid out otherwise than the source: a path the file
    names, absolute or relative to its folder, that lies in ``old`` is named as the same path in
    ``new``, relative to the target's folder. A carry keeps a run at ``CARRY/<run>``, not at
    ``WORK/runs/<run>``: its evaluation, carried to ``CARRY/standard/<run>``, still finds it, and
    again once carried back in.
    """
    work, folder, there = work.resolve(), source.resolve().parent, target.resolve().parent
    moved = [(str(old.resolve()), str(new.resolve())) for old, new in moves]

    def place(path: str) -> str | None:
        for old, new in moved:
            if path == old or path.startswith(old + os.sep):
                return os.path.relpath(new + path[len(old) :], there)
        return None

    def rename(match: re.Match[str]) -> str:
        if match.group("absolute"):
            path = os.path.normpath(match.group("absolute"))
            return place(path) or os.path.relpath(path, folder)
        named = match.group("relative")
        return place(os.path.normpath(os.path.join(folder, named))) or named

    pattern = rf"""(?P<absolute>{re.escape(str(work))}[^"`\s]*)|(?<=["`])(?P<relative>\.\.?/[^"`\s]*)"""
    text = re.sub(pattern, rename, source.read_text())
    text = re.sub(r"""[^"`\s]*/site-packages/""", "", text)
    target.write_text(text)


def complete(run: Path) -> bool:
    """Whether ``run`` has learned all its tasks and made its evaluations (``results.json``)."""
    results = run / "results.json"
    return results.is_file() and bool(json.loads(results.read_text()).get("complete"))


def unfinished(work: Path, also: Sequence[str] = ()) -> list[Path]:
    """WORK's run folders whose results are not complete, and those named in ``also`` (finished
    runs something still needs: their newest checkpoint goes with them)."""
    runs = sorted(p for p in (work / "runs").iterdir() if (p / "config.json").is_file())
    return [run for run in runs if run.name in also or not complete(run)]


def carried_files(run: Path) -> list[Path]:
    """What of ``run`` is carried (paths relative to it)."""
    files = [Path(name) for name in TOP_FILES if (run / name).is_file()]
    checkpoints = sorted((run / "checkpoints").glob("task_*.safetensors"))
    tasks = [p for p in checkpoints if not p.name.endswith(".epoch.safetensors")]
    states = [p for p in checkpoints if p.name.endswith(".epoch.safetensors")]
    return files + [p.relative_to(run) for p in tasks[-1:] + states]


def _slim(source: Path, target: Path) -> None:
    """Copy a checkpoint or epoch state, ER's without its memory's windows."""
    from libero_bench.algos.er import without_memories
    from libero_bench.runs.saved_policy import CHECKPOINT, EPOCH_STATE
    from libero_bench.runs.state_files import load_state, save_state

    kind = EPOCH_STATE if source.name.endswith(".epoch.safetensors") else CHECKPOINT
    state = load_state(source, kind=kind)
    algo = state.get("algo", {})
    if isinstance(algo, dict) and "memories" in algo:
        state = {**state, "algo": without_memories(algo)}
        save_state(target, state, kind=kind)
    else:
        shutil.copy2(source, target)


def carry_out(work: Path, carry: Path, also: Sequence[str] = ()) -> dict[str, Any]:
    """Copy what each unfinished run of ``work`` (and each finished one named in ``also``) needs
    into ``carry``; returns the manifest."""
    if carry.exists():
        shutil.rmtree(carry)
    carry.mkdir(parents=True)
    manifest: dict[str, Any] = {"format": FORMAT, "data": {}, "dataset_files": {}, "runs": {}}
    for run in unfinished(work, also):
        files: dict[str, str] = {}
        for rel in carried_files(run):
            target = carry / run.name / rel
            target.parent.mkdir(parents=True, exist_ok=True)
            if rel.suffix == ".safetensors":
                _slim(run / rel, target)
            else:
                shutil.copy2(run / rel, target)
            files[rel.as_posix()] = sha256(target)
        datasets = {}  # a finished run is evaluated from its checkpoint: it needs no dataset
        for dataset in [] if complete(run) else run_datasets(run):
            key = dataset.name
            if key not in manifest["data"]:
                manifest["data"][key] = data_digest(dataset)
                manifest["dataset_files"][key] = pack_dataset(dataset, carry / "datasets" / key)
            datasets[key] = manifest["data"][key]
        manifest["runs"][run.name] = {"files": files, "datasets": datasets}
    (carry / "carry.json").write_text(json.dumps(manifest, indent=1, sort_keys=True) + "\n")
    return manifest


def _stage(source: Path, staging: Path, entry: dict[str, Any], carried: dict[str, dict[str, str]]) -> None:
    """Copy one carried run into ``staging``, checking its files and that its datasets are the ones
    it learned from; a dataset that is not where the run looks for it is put there from
    ``carried`` (name -> its files' SHA-256) when the carry holds it."""
    for rel, digest in entry["files"].items():
        target = staging / rel
        target.parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(source / rel, target)
        if sha256(target) != digest:
            raise SystemExit(f"{source / rel} differs from what carry.json records")
    results = staging / "results.json"
    recorded = (
        [r["key"] for r in json.loads(results.read_text()).get("rollouts", [])] if results.is_file() else []
    )
    (staging / ".work").mkdir(exist_ok=True)  # the rollouts made so far stayed behind: RunFolder.left_behind
    (staging / ".work" / "left_behind.json").write_text(json.dumps(sorted(recorded)) + "\n")
    for dataset in [] if complete(staging) else run_datasets(staging):
        want = entry["datasets"].get(dataset.name)
        if not dataset.exists() and dataset.name in carried:
            unpack_dataset(source.parent / "datasets" / dataset.name, carried[dataset.name], dataset)
        if not dataset.is_dir():
            raise SystemExit(
                f"{source.name} needs its dataset {dataset}: make it first (benchmarks/lifelong.sh WORK data)"
            )
        if data_digest(dataset) != want:
            hint = (
                "; move it aside and carry-in puts the carried copy there" if dataset.name in carried else ""
            )
            raise SystemExit(
                f"{dataset} is not the dataset {source.name} learned from (digest {want[:12]}): "
                f"a run carried in must go on from the same demonstrations{hint}"
            )


def carry_in(carry: Path, work: Path) -> list[str]:
    """Put the carried runs back into ``work/runs``, and their datasets where they look for them
    when nothing is there (a dataset that is there must be the same); returns the runs put back.
    A run already in ``work`` is left as it is."""
    manifest = json.loads((carry / "carry.json").read_text())
    if manifest.get("format") != FORMAT:
        raise SystemExit(f"{carry / 'carry.json'} is not a {FORMAT} manifest")
    placed = []
    for name, entry in sorted(manifest["runs"].items()):
        run = work / "runs" / name
        if run.exists():
            print(f"{run} is here already: left as it is")
            continue
        staging = work / "runs" / f".{name}.carry"
        shutil.rmtree(staging, ignore_errors=True)
        try:
            _stage(carry / name, staging, entry, manifest.get("dataset_files", {}))
        except BaseException:
            shutil.rmtree(staging, ignore_errors=True)  # nothing half put back
            raise
        staging.rename(run)
        placed.append(name)
    return placed


def _frames(path: Path) -> Any:
    """A video's frames as one uint8 array (frames, height, width, 3)."""
    import av
    import numpy as np

    with av.open(str(path)) as container:
        return np.stack([f.to_ndarray(format="rgb24") for f in container.decode(video=0)])


def _table_difference(a: Path, b: Path) -> str:
    import numpy as np
    import pyarrow.parquet as pq

    ta, tb = pq.read_table(a), pq.read_table(b)
    if ta.schema != tb.schema or ta.num_rows != tb.num_rows:
        return f"other columns or rows ({ta.num_rows} and {tb.num_rows} rows)"
    apart = []
    for name in ta.column_names:
        x = np.asarray(ta.column(name).to_pylist(), dtype=np.float64)
        y = np.asarray(tb.column(name).to_pylist(), dtype=np.float64)
        if x.shape != y.shape:
            apart.append(f"{name} (other shape)")
        elif not np.array_equal(x, y):
            apart.append(f"{name} (max {np.max(np.abs(x - y)):.3g})")
    return ", ".join(apart) or "the same values (other bytes)"


def _video_difference(a: Path, b: Path) -> str:
    import numpy as np

    fa, fb = _frames(a), _frames(b)
    if fa.shape != fb.shape:
        return f"other frames ({fa.shape} and {fb.shape})"
    apart = np.abs(fa.astype(np.int16) - fb.astype(np.int16))
    frames = int(np.count_nonzero(apart.reshape(len(apart), -1).max(axis=1)))
    return (
        f"{frames}/{len(fa)} frames differ, max {int(apart.max())} levels, "
        f"{np.count_nonzero(apart) / apart.size:.2%} of values"
    )


def diff(carry: Path, dataset: Path) -> list[str]:
    """Compare the files of ``dataset`` (made again, on another machine: a few episodes are enough,
    as each episode is its own file) with the carried dataset of the same name, file by file: which
    are the same, and how the others differ (table columns; decoded video frames)."""
    manifest = json.loads((carry / "carry.json").read_text())
    files = manifest.get("dataset_files", {})
    if len(files) != 1 and dataset.name not in files:
        raise SystemExit(f"{carry} carries {', '.join(files) or 'no dataset'}, not {dataset.name}")
    name = dataset.name if dataset.name in files else next(iter(files))
    recorded, source = files[name], carry / "datasets" / name
    lines = []
    for rel in dataset_files(dataset):
        key = rel.as_posix()
        if key.startswith("meta/") or key == "README.md" or key not in recorded:
            continue  # the card and meta describe the whole dataset: other by construction
        if sha256(dataset / rel) == recorded[key]:
            lines.append(f"{key}: the same")
        elif rel.suffix == ".parquet":
            lines.append(f"{key}: {_table_difference(source / rel, dataset / rel)}")
        elif rel.suffix == ".mp4":
            lines.append(f"{key}: {_video_difference(source / rel, dataset / rel)}")
        else:
            lines.append(f"{key}: other bytes")
    if not lines:
        raise SystemExit(f"{dataset} has no table or video the carry records")
    return lines


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = parser.add_subparsers(dest="direction", required=True)
    out = sub.add_parser("out", help="pack WORK's unfinished runs into CARRY (replacing what it held)")
    out.add_argument("work", type=Path)
    out.add_argument("carry", type=Path)
    out.add_argument(
        "--also", action="append", default=[], metavar="RUN", help="a finished run to carry too (repeatable)"
    )
    back = sub.add_parser("in", help="put CARRY's runs back into WORK/runs")
    back.add_argument("carry", type=Path)
    back.add_argument("work", type=Path)
    compare = sub.add_parser(
        "diff", help="compare a dataset made again (a few episodes) with the carried one, file by file"
    )
    compare.add_argument("carry", type=Path)
    compare.add_argument("dataset", type=Path)
    args = parser.parse_args()
    if args.direction == "diff":
        print("\n".join(diff(args.carry, args.dataset)))
    elif args.direction == "out":
        manifest = carry_out(args.work, args.carry, args.also)
        size = sum(p.stat().st_size for p in args.carry.rglob("*") if p.is_file())
        print(f"carried {', '.join(manifest['runs']) or 'no run'} into {args.carry} ({size / 1e6:.1f} MB)")
    else:
        placed = carry_in(args.carry, args.work)
        print(f"put back {', '.join(placed) or 'no run'} into {args.work / 'runs'}")


if __name__ == "__main__":
    main()
