"""``libero-data validate``: is a dataset folder consistent, and do its episodes still succeed?

Checks, in order: ``meta/info.json`` against the episode table and the files on disk; each
episode's parquet rows and each camera's video frames against its length; our per-episode
metadata and MCAP logs; and optionally re-simulates episodes from their first stored state
with their stored actions (the replay must reproduce the stored states and end in success).

A replay is exact where the episode was made on this machine's numeric path (the same
``numeric_key``, see ``libero_data.numerics``) by the same simulator code. An episode made
elsewhere may depart in the last bits, which contact can grow: then the report says where the
replay began to depart, how far it went, and which parts of the two machines differ, and a
tolerance on the positions decides.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from libero_data.errors import InputError
from libero_data.pipeline.findings import Issue, Report
from libero_data.pipeline.resimulate import resimulate_episodes
from libero_data.pipeline.snapshot import EPISODES_META


def validate(
    root: str | Path,
    *,
    resimulate: int = 0,
    tolerance: float = 0.0,
    on_step: Callable[[str], None] | None = None,
) -> Report:
    """Check a dataset folder; ``report.issues`` lists every inconsistency found.

    ``tolerance`` (m or rad) is how far the re-simulated joint and object positions of an
    episode made on another numeric path, or by other simulator code, may depart from the
    stored ones; episodes made here are always held to an exact replay.
    """
    if not tolerance >= 0:
        raise InputError(f"the tolerance must be a non-negative number, got {tolerance}", field="tolerance")
    root = Path(root)
    issues: list[Issue] = []
    report = Report(issues=issues)
    note = on_step or (lambda message: None)
    info_path = root / "meta" / "info.json"
    if not info_path.is_file():
        issues.append(Issue(str(root), "not a LeRobot dataset (meta/info.json is missing)"))
        return report
    try:
        info = json.loads(info_path.read_text())
    except (OSError, json.JSONDecodeError) as exc:
        issues.append(Issue(str(info_path), f"unreadable ({exc})"))
        return report
    note("episode table")
    try:
        episodes = episode_table(root)
    except Exception as exc:  # any failure to read the table is a finding, not a crash
        issues.append(
            Issue(str(root / "meta" / "episodes"), f"unreadable episode table ({type(exc).__name__}: {exc})")
        )
        return report
    report.episodes = len(episodes)
    report.frames = int(sum(e["length"] for e in episodes))
    if info.get("total_episodes") != len(episodes):
        issues.append(
            Issue(
                str(info_path),
                f"total_episodes is {info.get('total_episodes')} but the episode table has {len(episodes)}",
            )
        )
    if info.get("total_frames") != report.frames:
        issues.append(
            Issue(
                str(info_path),
                f"total_frames is {info.get('total_frames')} but the episodes add up to {report.frames}",
            )
        )
    video_keys = [k for k, f in info.get("features", {}).items() if f.get("dtype") == "video"]

    note("data files")
    issues += _check_data(root, info, episodes)
    note("videos")
    issues += _check_videos(root, info, episodes, video_keys)
    note("libero-data metadata")
    ours = _check_ours(root, episodes)
    issues += ours[0]
    if resimulate and not issues:
        note("re-simulating")
        resimulate_episodes(root, info, episodes, ours[1], resimulate, tolerance, report, on_step=note)
    return report


def episode_table(root: Path) -> list[dict[str, Any]]:
    import pyarrow.parquet as pq

    files = sorted((root / "meta" / "episodes").glob("*/*.parquet"))
    if not files:
        raise FileNotFoundError("no episode metadata files")
    rows: list[dict[str, Any]] = []
    for path in files:
        table = pq.read_table(path, columns=None)
        names = [n for n in table.column_names if not n.startswith("stats/")]
        rows += table.select(names).to_pylist()
    rows.sort(key=lambda r: r["episode_index"])
    return rows


def _check_data(root: Path, info: dict[str, Any], episodes: list[dict[str, Any]]) -> list[Issue]:
    import pyarrow.parquet as pq

    issues: list[Issue] = []
    template = info["data_path"]
    counts: dict[str, dict[int, tuple[int, list[int]]]] = {}
    for ep in episodes:
        rel = template.format(chunk_index=ep["data/chunk_index"], file_index=ep["data/file_index"])
        path = root / rel
        if rel not in counts:
            if not path.is_file():
                issues.append(Issue(rel, f"missing (episode {ep['episode_index']})"))
                counts[rel] = {}
                continue
            try:
                table = pq.read_table(path, columns=["episode_index", "frame_index"])
            except Exception as exc:
                issues.append(Issue(rel, f"unreadable parquet ({type(exc).__name__}: {exc})"))
                counts[rel] = {}
                continue
            per: dict[int, tuple[int, list[int]]] = {}
            eps = table.column("episode_index").to_numpy()
            frames = table.column("frame_index").to_numpy()
            for e in np.unique(eps):
                idx = frames[eps == e]
                per[int(e)] = (len(idx), idx.tolist())
            counts[rel] = per
        per = counts[rel]
        if not per:
            continue
        n, frames_of = per.get(int(ep["episode_index"]), (0, []))
        if n != ep["length"]:
            issues.append(
                Issue(rel, f"episode {ep['episode_index']} has {n} rows but its length is {ep['length']}")
            )
        elif frames_of != list(range(n)):
            issues.append(Issue(rel, f"episode {ep['episode_index']} frame_index is not 0..{n - 1}"))
    return issues


def _check_videos(
    root: Path, info: dict[str, Any], episodes: list[dict[str, Any]], keys: list[str]
) -> list[Issue]:
    import av

    issues: list[Issue] = []
    template = info.get("video_path")
    if keys and not template:
        return [Issue("meta/info.json", "has video features but no video_path")]
    fps = float(info["fps"])
    cache: dict[str, list[float] | None] = {}
    for key in keys:
        for ep in episodes:
            rel = str(template).format(
                video_key=key,
                chunk_index=ep[f"videos/{key}/chunk_index"],
                file_index=ep[f"videos/{key}/file_index"],
            )
            if rel not in cache:
                path = root / rel
                if not path.is_file():
                    issues.append(Issue(rel, f"missing video (episode {ep['episode_index']}, {key})"))
                    cache[rel] = None
                    continue
                try:
                    with av.open(str(path)) as container:
                        stream = container.streams.video[0]
                        base = float(stream.time_base or 0)
                        stamps = [float(p.pts) * base for p in container.demux(stream) if p.pts is not None]
                    cache[rel] = sorted(stamps)
                except Exception as exc:
                    issues.append(Issue(rel, f"unreadable video ({type(exc).__name__}: {exc})"))
                    cache[rel] = None
                    continue
            times = cache[rel]
            if times is None:
                continue
            start = float(ep[f"videos/{key}/from_timestamp"])
            end = float(ep[f"videos/{key}/to_timestamp"])
            half = 0.5 / fps
            n = sum(1 for t in times if start - half <= t < end - half)
            if n != ep["length"]:
                issues.append(
                    Issue(
                        rel,
                        f"episode {ep['episode_index']} has {n} video frames ({key}) but its length is {ep['length']}",
                    )
                )
    return issues


def _check_ours(root: Path, episodes: list[dict[str, Any]]) -> tuple[list[Issue], list[dict[str, Any]]]:
    issues: list[Issue] = []
    path = root / "meta" / EPISODES_META
    if not path.is_file():
        issues.append(Issue(str(path.relative_to(root)), "missing (not made by libero-data?)"))
        return issues, []
    rows = [json.loads(line) for line in path.read_text().splitlines() if line.strip()]
    if len(rows) != len(episodes):
        issues.append(Issue(str(path.relative_to(root)), f"{len(rows)} rows for {len(episodes)} episodes"))
        return issues, rows
    for row, ep in zip(rows, episodes, strict=True):
        if row.get("episode_index") != ep["episode_index"] or row.get("length") != ep["length"]:
            issues.append(
                Issue(
                    str(path.relative_to(root)),
                    f"row for episode {ep['episode_index']} disagrees with the episode table",
                )
            )
    mcap_dir = root / "mcap"
    if mcap_dir.is_dir():
        from libero_data.record.mcap_log import count_messages

        for ep in episodes:
            log = mcap_dir / f"episode_{ep['episode_index']:06d}.mcap"
            rel = str(log.relative_to(root))
            if not log.is_file():
                issues.append(Issue(rel, "missing MCAP log"))
                continue
            try:
                n = count_messages(log, "/action")
            except Exception as exc:
                issues.append(Issue(rel, f"unreadable MCAP log ({type(exc).__name__}: {exc})"))
                continue
            if n != ep["length"]:
                issues.append(Issue(rel, f"{n} action messages but the episode has {ep['length']} frames"))
    return issues, rows


__all__ = ["Issue", "Report", "validate"]
