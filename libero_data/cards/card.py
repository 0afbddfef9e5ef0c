"""Rendering the dataset card from ``template.md`` (``string.Template`` placeholders)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from string import Template

TEMPLATE = Path(__file__).with_name("template.md")


@dataclass(frozen=True)
class CardTask:
    index: int
    name: str
    language: str
    goal: str
    episodes: int
    attempts: int
    successes: int
    #: of the successes, those within the task's standard step limit (None: not known)
    within: int | None = None

    @property
    def success_rate(self) -> float:
        return self.successes / self.attempts if self.attempts else float("nan")

    def within_cell(self) -> str:
        """The task table's *within the standard limit* cell."""
        if self.within is None or not self.attempts:
            return "–"
        return f"{self.within / self.attempts:.0%} ({self.within}/{self.attempts})"


@dataclass(frozen=True)
class SuccessColumn:
    """What a card's success column counts, in the card's words: its ``header`` in the task
    table (and the *All tasks* line), the ``note`` under the table, and whether it counts the
    source's successful attempts of all its attempts (``of_attempts``: a search that keeps only
    its successes) or the kept episodes after whose last action the task's goal holds."""

    header: str
    note: str
    of_attempts: bool


#: The scripted expert's: its search keeps an episode only where an attempt reached the goal.
EXPERT_SUCCESS = SuccessColumn(
    header="expert success",
    note=(
        "*Expert success* is the share of the expert's attempts on that task that reached the goal\n"
        "(failed attempts are discarded, never stored); *within the standard limit* the share that reached\n"
        "it in no more steps than the task's standard limit (*Episode lengths* below)."
    ),
    of_attempts=True,
)
#: Any other source's, unless it says otherwise: checked on the episodes themselves, whatever
#: the source thought of them.
GOAL_REACHED = SuccessColumn(
    header="goal reached",
    note=(
        "*Goal reached* is the share of the task's episodes after whose last action the task's goal holds, "
        "checked on each episode's stored final state when its images were rendered (the source's own verdict "
        "is not counted); *within the standard limit* the share that also took no more steps than the task's "
        "standard limit (*Episode lengths* below)."
    ),
    of_attempts=False,
)


def _cell(text: str) -> str:
    return text.replace("|", "\\|").replace("\n", " ")


#: How the card names each camera.
CAMERA_WORDS = {"agentview": "agentview", "eye_in_hand": "eye-in-hand"}


#: What the card says of images drawn at full render quality (LIBERO's renderer as it is).
FULL_IMAGE_NOTE = (
    "They equal, pixel for pixel, what LIBERO's own `OffScreenRenderEnv` renders for the same state, turned "
    "upright (rotated by 180°: `image[::-1, ::-1]` of LIBERO's arrays). LIBERO's `env.step` instead returns "
    "images of the scene two physics substeps (4 ms) before the state it returns with them."
)
#: ... and at fast render quality.
FAST_IMAGE_NOTE = (
    "They are drawn at `fast` render quality: the same scene, cameras and lights as LIBERO's own "
    "`OffScreenRenderEnv` (turned upright), but from simplified copies of the visual meshes, so they differ "
    "from LIBERO's images by the amounts measured on this dataset's frames (settings table, render quality). "
    "`libero-data rerender --render-quality full` draws LIBERO's exact images from the same states."
)


#: How the card says an expert's demonstrations were made (the defaults of :func:`render_card`).
EXPERT_HOW = (
    "Human demonstrations are not used. A scripted expert reads each task's goal predicates from "
    "its BDDL file, plans them into skills (pick, place on, place in, open/close a drawer or a "
    "hinged door, turn a knob, push) and drives the robot with 7-D OSC delta actions computed "
    "from the simulator's privileged state. Each episode's style (speed, small waypoint jitter, "
    "action noise) is drawn from its own seed, so episodes of a task are not copies of each other. "
    "Episodes are searched without cameras; kept episodes are re-rendered frame by frame from "
    "their stored MuJoCo states."
)
EXPERT_TASK_NOTE = (
    "Task: the robot must make the goal formula of the task's BDDL file true; an episode ends at "
    "the first frame after which the goal holds. Randomisations: object placement (LIBERO's init "
    "states or its placement sampler), the arm's starting pose (the init states' or, on sampler "
    "starts, seeded joint noise), fixture placement (seeded per episode), the expert's style."
)
EXPERT_REPRODUCIBILITY = (
    "Replaying an episode's stored actions from its first stored state gives its stored states bit "
    "for bit on any machine whose numeric path has the key listed under *Settings and versions* "
    "(`numeric path <key>`): an x86-64 CPU with AVX2 and FMA, the same library versions, and the "
    "numeric path `libero-data` pins (OpenBLAS's Sandybridge kernel, NumPy without AVX-512). "
    "`libero-data validate --resimulate N` checks it; on a machine with another key it reports where "
    "and by how much a replay departs, and `--tolerance` decides. The images also depend on the "
    "OpenGL renderer listed there."
)

#: ``render_card``'s sections for the scripted expert's demonstrations.
EXPERT_SECTIONS = {
    "kind_tag": "scripted-demonstrations",
    "how_made": EXPERT_HOW,
    "task_note": EXPERT_TASK_NOTE,
    "reproducibility": EXPERT_REPRODUCIBILITY,
}
#: ... and for demonstrations whose source says nothing of them (each section it leaves out).
UNDESCRIBED_SECTIONS = {
    "kind_tag": "demonstrations",
    "how_made": (
        "The demonstration source that made these episodes does not describe how. Each kept episode's images "
        "are rendered frame by frame from its stored MuJoCo states."
    ),
    "task_note": "Task: the robot must make the goal formula of the task's BDDL file true.",
    "reproducibility": (
        "The stored states are the source's. `libero-data validate --resimulate N` replays episodes' stored "
        "actions from their first stored state and reports where and by how much the replay departs from the "
        "stored states. The images also depend on the OpenGL renderer listed under *Settings and versions*."
    ),
}


def render_card(
    *,
    title: str,
    summary: str,
    suite: str,
    repo_id: str,
    load_path: str,
    command: str,
    tasks: list[CardTask],
    frames: int | None,
    fps: int,
    image_size: int,
    sim_state_width: int,
    settings: dict[str, str],
    start_note: str,
    expert_note: str = "",
    lengths: str = "",
    camera_keys: dict[str, str] | None = None,
    image_note: str = FULL_IMAGE_NOTE,
    kind_tag: str = "scripted-demonstrations",
    how_made: str = EXPERT_HOW,
    task_note: str = EXPERT_TASK_NOTE,
    reproducibility: str = EXPERT_REPRODUCIBILITY,
    success: SuccessColumn = EXPERT_SUCCESS,
) -> str:
    """The card text; every number comes from the caller (nothing is guessed here)."""
    from libero_data.record.features import CAMERA_KEYS

    keys = camera_keys or CAMERA_KEYS
    rows = []
    for t in tasks:
        rate = f"{t.success_rate:.0%} ({t.successes}/{t.attempts})" if t.attempts else "–"
        rows.append(
            f"| {t.index} | `{t.name}` | {_cell(t.language)} | `{_cell(t.goal)}` | {t.episodes} | {rate} "
            f"| {t.within_cell()} |"
        )
    settings_rows = "\n".join(f"| {_cell(k)} | {_cell(str(v))} |" for k, v in settings.items())
    # The split's size in the YAML header: `datasets.load_dataset(folder)` keys its cache on
    # this header, so a dataset regenerated at the same path with other frames is read
    # afresh instead of from the stale cache.
    dataset_info = (
        "" if frames is None else f"dataset_info:\n  splits:\n  - name: train\n    num_examples: {frames}\n"
    )
    return Template(TEMPLATE.read_text()).substitute(
        title=title,
        summary=summary,
        suite_tag=suite.replace("/", "-"),
        repo_id=repo_id,
        load_path=load_path,
        command=command,
        episodes=sum(t.episodes for t in tasks),
        frames="—" if frames is None else frames,
        dataset_info=dataset_info,
        cameras=" and ".join(f"{CAMERA_WORDS[c]} (`{k}`)" for c, k in keys.items()),
        first_camera=next(iter(keys.values())),
        fps=fps,
        tasks=len(tasks),
        image_size=image_size,
        task_rows="\n".join(rows),
        sim_state_width=sim_state_width,
        settings_rows=settings_rows,
        start_note=start_note,
        expert_note=expert_note,
        lengths=lengths or "Not stated.",
        image_note=image_note,
        kind_tag=kind_tag,
        how_made=how_made,
        task_note=task_note,
        reproducibility=reproducibility,
        success_header=success.header,
        success_note=success.note,
    )


def with_data_size(card: str, data_bytes: int) -> str:
    """The card with its split's data size (the bytes of its parquet files) in the YAML header.

    ``datasets.load_dataset(folder)`` keys its cache on the header alone (not on the files), so
    two datasets in folders of the same name and with as many frames would read each other's
    cache; with the size beside the frame count they do not. A card without a split is returned
    as it is.
    """
    lines = card.split("\n")
    for i, line in enumerate(lines):
        if line.startswith("    num_examples: ") and not lines[i + 1].startswith("    num_bytes: "):
            return "\n".join([*lines[: i + 1], f"    num_bytes: {int(data_bytes)}", *lines[i + 1 :]])
        if line == "---" and i > 0:
            break
    return card
