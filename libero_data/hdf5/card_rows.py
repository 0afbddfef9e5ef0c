"""What the card of an imported dataset says: human demonstrations, where they came from, how
their states replayed here, where they began, and the no-op frames left out."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

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
    began = sorted({int(i["init_index"]) for i in infos if int(i.get("init_index", -1)) >= 0})
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
    "(settings: replay under this simulator), and the images are rendered again from the stored states. "
    "In the task table, *expert success* counts the file's demonstrations kept: a demonstration whose states "
    "this simulator does not reproduce within the import's tolerance is left out."
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
#: ``render_card``'s arguments for an imported dataset.
HUMAN_SECTIONS = {
    "kind_tag": "human-demonstrations",
    "how_made": HUMAN_HOW,
    "task_note": HUMAN_TASK_NOTE,
    "reproducibility": HUMAN_REPRODUCIBILITY,
}
