"""Re-simulating stored episodes and judging the replays (``validate --resimulate``).

A replay restores an episode's first stored state and re-runs its stored actions. It is exact
where the episode was made on this machine's numeric path by the same simulator code; made
elsewhere it may depart in the last bits, and the verdict says where, how far, what differs
between the two machines, and whether the tolerance covers it.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from libero_data.pipeline.findings import Issue, Report
from libero_data.record.features import ACTION, StoredColumns, sim_states


def resimulate_episodes(
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
    """Re-simulate ``count`` episodes spread over the dataset and judge each replay."""
    from libero_data.numerics import machine_fingerprint
    from libero_data.provenance import expert_code
    from libero_data.sim import EnvConfig, LiberoEnv

    assert report.issues is not None
    here = Origin(machine_fingerprint(), expert_code())
    machines = recorded_machines(root)
    imported_tolerance = _import_tolerance(root)
    picks = sorted({int(i) for i in np.linspace(0, len(episodes) - 1, min(count, len(episodes)))})
    envs: dict[str, LiberoEnv] = {}
    try:
        for i in picks:
            ep, row = episodes[i], ours[i]
            actions, states = stored_episode(root, info, ep)
            name = row["task_name"]
            if name not in envs:
                bddl = root / "meta" / "bddl" / f"{name}.bddl"
                source = bddl if bddl.is_file() else f"{row['suite']}/{name}"
                envs[name] = LiberoEnv(source, EnvConfig(cameras=()))
            env = envs[name]
            on_step(f"re-simulating episode {ep['episode_index']} ({name})")
            if "fixtures" in row:  # imported (libero-data import): judged step by step
                judge_imported(env, row, states, actions, max(tolerance, imported_tolerance), report)
                continue
            result = replay(env, int(row["reset_seed"]), states, actions)
            key = str(row.get("numeric_key", "unknown"))
            made = Origin(machines.get(key, {"numeric_key": key}), str(row.get("expert_code", "unknown")))
            judge(f"episode {ep['episode_index']}", result, made, here, tolerance, report)
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


def judge(where: str, replay: Replay, made: Origin, here: Origin, tolerance: float, report: Report) -> None:
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


def judge_imported(
    env: Any,
    row: dict[str, Any],
    states: np.ndarray,
    actions: np.ndarray,
    limit: float,
    report: Report,
) -> None:
    """An imported demonstration, re-simulated one step at a time from each stored state (its
    fixtures where they stood): the largest deviation within ``limit`` (the import's tolerance,
    or the one asked if larger), and the goal reached after its last action."""
    from libero_data.hdf5.checks import step_replay
    from libero_data.hdf5.fixtures import place_fixtures

    assert report.issues is not None
    where = f"episode {row['episode_index']}"
    dropped = set(row.get("noop_frames", []))
    frames = np.array([i for i in range(int(row.get("frames_in_file", len(actions)))) if i not in dropped])
    env.reset(seed=int(row["reset_seed"]), render=False)
    place_fixtures(env, row["fixtures"])
    result = step_replay(env, states, actions, frames if len(frames) == len(actions) else None)
    report.resimulated += 1
    if env.success():
        report.resimulated_ok += 1
    else:
        report.issues.append(Issue(where, "does not reach its goal after its last action when re-simulated"))
    if result.worst > limit:
        report.issues.append(
            Issue(
                where,
                f"stepping its stored states deviates by up to {result.worst:.2e} (joint and object positions, "
                f"m or rad), more than the tolerance of {limit:g}",
            )
        )


def _import_tolerance(root: Path) -> float:
    """The tolerance an imported dataset's demonstrations were checked with (0 for others)."""
    try:
        meta = json.loads((root / "meta" / "libero.json").read_text())
        return float(meta.get("request", {}).get("import_tolerance", 0.0))
    except (OSError, ValueError, AttributeError):
        return 0.0


def recorded_machines(root: Path) -> dict[str, dict[str, Any]]:
    """The numeric fingerprints listed in ``meta/libero.json``, by key (empty if none)."""
    try:
        meta = json.loads((root / "meta" / "libero.json").read_text())
    except (OSError, ValueError):
        return {}
    found = meta.get("machines") if isinstance(meta, dict) else None
    if not isinstance(found, list):
        return {}
    return {str(m["numeric_key"]): m for m in found if isinstance(m, dict) and "numeric_key" in m}


def stored_episode(root: Path, info: dict[str, Any], ep: dict[str, Any]) -> tuple[np.ndarray, np.ndarray]:
    """An episode's stored actions (float32, as executed) and MuJoCo states (true width)."""
    import pyarrow.parquet as pq

    rel = info["data_path"].format(chunk_index=ep["data/chunk_index"], file_index=ep["data/file_index"])
    stored = StoredColumns.of(info["features"])
    sim, sim_dim = stored.sim_state, stored.sim_state_dim
    table = pq.read_table(root / rel, columns=["episode_index", ACTION, sim, sim_dim])
    mask = table.column("episode_index").to_numpy() == ep["episode_index"]
    actions = np.stack(table.column(ACTION).to_numpy(zero_copy_only=False)[mask]).astype(np.float32)
    states = sim_states(np.stack(table.column(sim).to_numpy(zero_copy_only=False)[mask]), sim)
    dims = table.column(sim_dim).to_numpy(zero_copy_only=False)[mask]
    dim = int(np.asarray(dims[0]).reshape(-1)[0])
    return actions, states[:, :dim]
