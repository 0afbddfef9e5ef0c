"""LIBERO's HDF5 files as a demonstration source (``libero-data import``): each demonstration,
checked in the driver before ``generate`` starts (:mod:`~libero_data.pipeline.importer`), becomes
the record of one slot; its frames are drawn with its fixtures where its stored model XML had
them; the card says the episodes are human demonstrations, where they came from, how their
states replayed here, where they began, and the no-op frames left out.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from libero_data.cards.card import SuccessColumn
from libero_data.errors import DatasetError
from libero_data.pipeline.sources.base import (
    CardPart,
    DemoSource,
    EpisodeRecord,
    register_source,
    stored_starts,
)

if TYPE_CHECKING:
    from libero_data.hdf5.reader import LiberoFile
    from libero_data.pipeline.request import GenerateRequest, Slot
    from libero_data.sim import LiberoEnv

#: The demonstrator an imported episode names.
HUMAN = "human (LIBERO's teleoperated demonstrations)"
#: The card's settings rows that say nothing of human demonstrations (no expert, seed or attempts;
#: an episode is kept as recorded, with the steps its recorder took after the goal).
NOT_APPLICABLE = ("seed", "attempts per episode (at most)", "steps after the goal", "expert code")


class LiberoHDF5(DemoSource):
    """LIBERO's HDF5 demonstration files: claims a request that names files it imported."""

    order = 50

    needs = "LIBERO HDF5 files, one per task (libero-data import makes the request)"

    def claims(self, request: GenerateRequest) -> bool:
        return bool(request.imported)

    def set_scene(self, env: Any, record: EpisodeRecord) -> None:
        from libero_data.hdf5.fixtures import place_fixtures

        super().set_scene(env, record)
        if record.fixtures is not None:  # where its fixtures stood when it was recorded
            place_fixtures(env, record.fixtures)

    def card(self, request: GenerateRequest, suite: str, infos: list[dict[str, Any]]) -> CardPart:
        return CardPart(
            summary=(
                f"Human demonstrations of the LIBERO suite `{suite}` (LIBERO's own, imported from its HDF5 files), "
                "re-rendered from their stored states with libero-data in LeRobot v3 format."
            ),
            start_note=import_start_note(infos),
            settings={
                "starts": "where each human demonstration began, measured (began from a stored init state)",
                **import_settings(request.imported, infos, request.drop_noops),
            },
            not_applicable=NOT_APPLICABLE,
            sections=HUMAN_SECTIONS,
            success=KEPT_OF_FILE,
        )


register_source(LiberoHDF5("libero_hdf5"))


def demo_record(
    env: LiberoEnv,
    task_id: str,
    request: GenerateRequest,
    source: LiberoFile,
    slot: Slot,
    stored: np.ndarray | None,
) -> EpisodeRecord:
    """One demonstration's record: its states and actions, checked, with where it came from."""
    from libero_data.hdf5.checks import START_MATCH, nearest_init, noop_frames, step_replay
    from libero_data.hdf5.fixtures import fixture_poses, place_fixtures
    from libero_data.hdf5.reader import DROPPED_AT_START

    name = Path(source.path).name
    if slot.k >= len(source.demo_keys):
        return _not_kept(f"{name} holds {len(source.demo_keys)} demonstrations, not {slot.k + 1}")
    key = source.demo_keys[slot.k]
    demo = source.demo(key)
    where = f"{source.path}, {key}"
    if demo.states.shape[1] != env.state_dim:
        raise DatasetError(
            f"{where}: states are {demo.states.shape[1]} wide but {task_id}'s scene here has {env.state_dim}: "
            "not the same scene"
        )
    fixtures = fixture_poses(demo.model_xml, env, where)
    env.reset(seed=0, render=False)
    place_fixtures(env, fixtures)
    replay = step_replay(env, demo.states, demo.actions)
    if replay.worst > request.import_tolerance:
        return _not_kept(
            f"{key}: stepping its stored states deviates by up to {replay.worst:.2e} (joint and object positions, "
            f"m or rad), more than the tolerance of {request.import_tolerance:g}"
        )
    nearest, distance = (
        (-1, float("nan")) if stored is None else nearest_init(env, demo.states[0], stored, DROPPED_AT_START)
    )
    keep = ~noop_frames(demo.actions) if request.drop_noops else np.ones(len(demo.actions), dtype=bool)
    keep[-1] = True  # the last frame carries the final state
    if keep.sum() < 2:
        return _not_kept(f"{key}: fewer than 2 frames are left once its no-op frames are dropped")
    return EpisodeRecord(
        success=True,
        attempts=1,
        code="human",
        machine={"numeric_key": "unknown"},
        init_index=nearest if distance <= START_MATCH else -1,
        reset_seed=0,
        expert_seed=-1,
        actions=demo.actions[keep],
        states=demo.states[keep],
        final_state=replay.final_state,
        fixtures=fixtures,
        details={
            "demonstrator": HUMAN,
            "source_file": name,
            "demo_key": key,
            "frames_in_file": len(demo.actions),
            "noops_dropped": int((~keep).sum()),
            "noop_frames": [int(i) for i in np.flatnonzero(~keep)],
            "init_nearest": nearest,
            "init_distance": None if np.isnan(distance) else round(distance, 5),
            "replay_worst": float(f"{replay.worst:.3e}"),
            "replay_mean": float(f"{replay.mean:.3e}"),
        },
    )


def _not_kept(reason: str) -> EpisodeRecord:
    return EpisodeRecord(success=False, attempts=1, failures=(reason,), code="human")


#: How an import pairs states, actions and images, and why (the card's words).
PAIRING = (
    "LIBERO's `create_dataset.py` drops each demonstration's first 5 steps and stores at index k the state "
    "before action k next to the observation after it; this import keeps the states and actions and renders "
    "each frame's images again from its own state, so frame k is the state before action k, its image drawn "
    "from that state (upright), and its action: as in every libero-data dataset. LIBERO's stored images are "
    "not used."
)


def import_settings(
    imported: tuple[str, ...], infos: list[dict[str, Any]], drop_noops: bool
) -> dict[str, str]:
    """The settings rows of an imported dataset's card."""
    from libero_data.hdf5.checks import NOOP_ARM, START_MATCH

    rows = {
        "demonstrations": "human: LIBERO's teleoperated demonstrations, imported from its HDF5 files",
        "imported from": ", ".join(Path(p).name for p in imported),
        "pairing": PAIRING,
    }
    if not infos:
        return rows
    worst = np.array([float(i.get("replay_worst", 0.0)) for i in infos])
    rows["replay under this simulator"] = (
        "each stored state stepped with its action against the next stored state: largest position deviation "
        f"per episode median {np.median(worst):.1e}, largest {worst.max():.1e} (m or rad)"
    )
    began = [i for i in infos if int(i.get("init_index", -1)) >= 0]
    distances = [float(i["init_distance"]) for i in infos if i.get("init_distance") is not None]
    rows["began from a stored init state"] = (
        f"{len(began)} of {len(infos)} episodes (every object within {START_MATCH * 1000:g} mm of where a stored "
        "init state puts it after the same 5 steps; `init_index`, `init_nearest` and `init_distance` per episode "
        "in meta/libero_episodes.jsonl"
        + (f"; nearest distance median {np.median(distances) * 1000:.1f} mm" if distances else "")
        + "). libero-bench's held-out evaluation skips the init states an episode began from."
    )
    if drop_noops:
        per_task: dict[str, list[int]] = {}
        for i in infos:
            per_task.setdefault(str(i["task_name"]), []).append(int(i.get("noops_dropped", 0)))
        for name, counts in per_task.items():
            rows[f"no-op frames dropped: {name}"] = (
                f"{sum(counts)} in all; per episode: {', '.join(str(c) for c in counts)}"
            )
        rows["no-op rule"] = (
            f"a frame whose six arm commands are all below {NOOP_ARM:g} and whose gripper command equals the "
            "frame before's (the arm does not move, the gripper does not change); a demonstration's last frame is kept"
        )
    else:
        rows["no-op frames"] = "kept (`--drop-noops` leaves them out)"
    return rows


def import_start_note(infos: list[dict[str, Any]]) -> str:
    """Where the card says an imported dataset's episodes began."""
    began = stored_starts(infos)
    return (
        "Human demonstrations do not say where they began. Each one's first kept state was compared with LIBERO's "
        f"50 stored init states (settings: began from a stored init state): {len(began)} distinct init states "
        "were found to be starts of these episodes, and a policy evaluated on them would have seen its starts in "
        "training; libero-bench's held-out evaluation leaves them out."
    )


#: The card's sections for imported (human) demonstrations.
HUMAN_HOW = (
    "These are LIBERO's own human demonstrations (teleoperated with a 3D mouse), read from the HDF5 files "
    "LIBERO distributes and checked under this simulator: each demonstration's fixtures are placed where its "
    "stored model XML had them, each stored state is stepped with its action and compared with the next one "
    "(settings: replay under this simulator), and the images are rendered again from the stored states."
)
#: The task table's success column of an import: the file's demonstrations kept.
KEPT_OF_FILE = SuccessColumn(
    header="kept",
    note=(
        "*Kept* is the share of the file's demonstrations of that task that were kept: a demonstration whose "
        "states this simulator does not reproduce within the import's tolerance is left out; *within the "
        "standard limit* the share kept that took no more steps than the task's standard limit (*Episode "
        "lengths* below)."
    ),
    of_attempts=True,
)
HUMAN_TASK_NOTE = (
    "Task: the robot must make the goal formula of the task's BDDL file true. Each demonstration is stored "
    "as LIBERO recorded it (its first 5 steps dropped by LIBERO), ending where the person stopped."
)
HUMAN_REPRODUCIBILITY = (
    "The states are LIBERO's, recorded with another MuJoCo version on another machine: replaying a "
    "demonstration's actions open loop from its first state drifts away from them, as contact-rich replays "
    "do. `libero-data validate --resimulate N` checks instead what the import checked: each stored state "
    "stepped with its action against the next, within the import's tolerance (recorded in meta/libero.json), "
    "and the goal reached after the last action. The images depend on the OpenGL renderer listed under "
    "*Settings and versions*."
)
#: ``render_card``'s sections for an imported dataset.
HUMAN_SECTIONS = {
    "kind_tag": "human-demonstrations",
    "how_made": HUMAN_HOW,
    "task_note": HUMAN_TASK_NOTE,
    "reproducibility": HUMAN_REPRODUCIBILITY,
}
