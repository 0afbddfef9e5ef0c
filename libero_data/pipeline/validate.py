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
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from libero_data.pipeline.snapshot import EPISODES_META
from libero_data.record.features import ACTION, OBS_SIM_STATE, OBS_SIM_STATE_DIM


@dataclass(frozen=True)
class Issue:
    where: str
    problem: str

    def __str__(self) -> str:
        return f"{self.where}: {self.problem}"


@dataclass
class Report:
    episodes: int = 0
    frames: int = 0
    resimulated: int = 0
    resimulated_ok: int = 0
    issues: list[Issue] | None = None
    #: Findings that are no inconsistency (replays made elsewhere, within the tolerance).
    notes: list[str] = field(default_factory=list)
    #: Re-simulated episodes made on another numeric path or by other simulator code that
    #: departed from their stored states by more than the tolerance.
    departed_elsewhere: int = 0

    @property
    def ok(self) -> bool:
        return not self.issues


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
        raise ValueError(f"the tolerance must be a non-negative number, got {tolerance}")
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
        episodes = _episode_table(root)
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
        _resimulate(root, info, episodes, ours[1], resimulate, tolerance, report, on_step=note)
    return report


def _episode_table(root: Path) -> list[dict[str, Any]]:
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


def _resimulate(
    root: Path,
    info: dict[str, Any],
    episodes: list[dict[str, Any]],
    ours: list[dict[str, Any]],
    count: int,
    tolerance: float,
    report: Report,
    *,
    on_step: Callable[[str], None],
) -> None:
    from libero_data.experts.report import expert_fingerprint
    from libero_data.numerics import machine_fingerprint
    from libero_data.sim import EnvConfig, LiberoEnv

    assert report.issues is not None
    here = Origin(machine_fingerprint(), expert_fingerprint())
    machines = _recorded_machines(root)
    picks = sorted({int(i) for i in np.linspace(0, len(episodes) - 1, min(count, len(episodes)))})
    envs: dict[str, LiberoEnv] = {}
    try:
        for i in picks:
            ep, row = episodes[i], ours[i]
            actions, states = _stored_episode(root, info, ep)
            name = row["task_name"]
            if name not in envs:
                bddl = root / "meta" / "bddl" / f"{name}.bddl"
                source = bddl if bddl.is_file() else f"{row['suite']}/{name}"
                envs[name] = LiberoEnv(source, EnvConfig(cameras=()))
            env = envs[name]
            on_step(f"re-simulating episode {ep['episode_index']} ({name})")
            result = replay(env, int(row["reset_seed"]), states, actions)
            key = str(row.get("numeric_key", "unknown"))
            made = Origin(machines.get(key, {"numeric_key": key}), str(row.get("expert_code", "unknown")))
            _judge(f"episode {ep['episode_index']}", result, made, here, tolerance, report)
    finally:
        for env in envs.values():
            env.close()


@dataclass(frozen=True)
class Origin:
    """Where an episode's bits come from: a numeric fingerprint and the simulator code."""

    machine: dict[str, Any]
    code: str

    def same_as(self, other: Origin) -> bool:
        key = self.machine.get("numeric_key")
        return (
            key not in (None, "unknown")
            and key == other.machine.get("numeric_key")
            and self.code == other.code
        )

    def differences(self, other: Origin) -> list[str]:
        """What differs between where this episode was made and ``other``, in words."""
        from libero_data.numerics import differences

        out = []
        if "cpu" not in self.machine:
            out.append("the dataset does not record the machine that made it")
        else:
            out += differences(self.machine, other.machine)
        if self.code != other.code:
            out.append(f"libero-data's simulator and expert code {self.code} there, {other.code} here")
        return out or ["nothing recorded differs"]


@dataclass(frozen=True)
class Replay:
    """A re-simulation against the stored states: where it departed and how far (positions)."""

    reached: bool
    #: The first frame whose state (positions or velocities) differs from the stored one.
    first: int | None
    #: Per frame t >= 1: the largest deviation of a joint or object position (m or rad).
    deviations: np.ndarray

    @property
    def worst(self) -> float:
        return float(self.deviations.max()) if self.deviations.size else 0.0

    @property
    def worst_frame(self) -> int:
        return int(np.argmax(self.deviations)) + 1 if self.deviations.size else 0

    def describe(self) -> str:
        return (
            f"departs from the stored states at frame {self.first} and reaches a largest deviation of "
            f"{self.worst:.2e} (joint and object positions, m or rad) at frame {self.worst_frame}"
        )


def replay(env: Any, reset_seed: int, states: np.ndarray, actions: np.ndarray) -> Replay:
    """Re-simulate ``actions`` from ``states[0]`` (fixtures placed from ``reset_seed``),
    comparing the positions of every frame with the stored ones."""
    env.reset(seed=reset_seed, render=False)
    env.set_state(states[0])
    positions = slice(1, 1 + int(env.sim.model.nq))  # the flat state is (time, qpos, qvel)
    deviations = np.zeros(max(len(actions) - 1, 0))
    first = None
    reached = env.success()
    for t, action in enumerate(actions):
        if t > 0:
            now = env.get_state()
            if first is None and not np.array_equal(now, states[t]):
                first = t
            deviations[t - 1] = np.abs(now[positions] - states[t][positions]).max()
        reached = env.advance(action)
    return Replay(reached=reached, first=first, deviations=deviations)


def _judge(where: str, replay: Replay, made: Origin, here: Origin, tolerance: float, report: Report) -> None:
    """Record a re-simulation's verdict in ``report`` (issues, notes, counts)."""
    assert report.issues is not None
    report.resimulated += 1
    if replay.reached:
        report.resimulated_ok += 1
    else:
        detail = f"; its replay {replay.describe()}" if replay.first is not None else ""
        report.issues.append(
            Issue(where, f"does not reach its goal when re-simulated from its first state{detail}")
        )
    if replay.first is None:
        return
    if made.same_as(here):
        report.issues.append(
            Issue(
                where,
                f"re-simulation {replay.describe()}, although this machine runs the numeric path that made it "
                f"({here.machine['numeric_key']}) with the same simulator code, where a replay is exact: "
                "the stored states or actions are not what the simulator produced",
            )
        )
        return
    why = "; ".join(made.differences(here))
    if replay.worst <= tolerance:
        report.notes.append(
            f"{where}: re-simulation {replay.describe()}, within the tolerance of {tolerance:g}; "
            f"it was made elsewhere ({why})"
        )
        return
    report.departed_elsewhere += 1
    limit = (
        f"more than the tolerance of {tolerance:g}"
        if tolerance > 0
        else "where an exact replay was asked for"
    )
    report.issues.append(
        Issue(
            where,
            f"re-simulation {replay.describe()}, {limit}; it was made on another numeric path or by other "
            f"code ({why})",
        )
    )


def _recorded_machines(root: Path) -> dict[str, dict[str, Any]]:
    """The numeric fingerprints listed in ``meta/libero.json``, by key (empty if none)."""
    try:
        meta = json.loads((root / "meta" / "libero.json").read_text())
    except (OSError, ValueError):
        return {}
    found = meta.get("machines") if isinstance(meta, dict) else None
    if not isinstance(found, list):
        return {}
    return {str(m["numeric_key"]): m for m in found if isinstance(m, dict) and "numeric_key" in m}


def _stored_episode(root: Path, info: dict[str, Any], ep: dict[str, Any]) -> tuple[np.ndarray, np.ndarray]:
    """An episode's stored actions (float32, as executed) and MuJoCo states (true width)."""
    import pyarrow.parquet as pq

    rel = info["data_path"].format(chunk_index=ep["data/chunk_index"], file_index=ep["data/file_index"])
    table = pq.read_table(root / rel, columns=["episode_index", ACTION, OBS_SIM_STATE, OBS_SIM_STATE_DIM])
    mask = table.column("episode_index").to_numpy() == ep["episode_index"]
    actions = np.stack(table.column(ACTION).to_numpy(zero_copy_only=False)[mask]).astype(np.float32)
    states = np.stack(table.column(OBS_SIM_STATE).to_numpy(zero_copy_only=False)[mask])
    dims = table.column(OBS_SIM_STATE_DIM).to_numpy(zero_copy_only=False)[mask]
    dim = int(np.asarray(dims[0]).reshape(-1)[0])
    return actions, states[:, :dim]
