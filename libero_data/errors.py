"""The errors this project raises for bad input and bad state, in the domain's words.

Every one is a :class:`LiberoDataError` whose message is one sentence naming what is wrong
and where (a task, a file and line, a field, a folder). The command-line tools turn exactly
these into ``error: <sentence>`` and exit code 2; anything else is a bug and shows its
traceback. Each also derives from the built-in exception a caller would expect
(``ValueError``, ``KeyError``, ``FileNotFoundError``), so ``except ValueError`` keeps working.

Messages speak of fields, not of command-line flags: :attr:`InputError.field` names the field
and the command line maps it to its option (``episodes_per_task`` -> ``--episodes-per-task``).
"""

from __future__ import annotations


def first_line(exc: BaseException) -> str:
    """The first line of an exception's message (its type's name when it has none): what a
    one-sentence error quotes of a library's longer one."""
    lines = str(exc).strip().splitlines()
    return lines[0] if lines else type(exc).__name__


class LiberoDataError(Exception):
    """Base of the expected failures: bad input or a folder in the wrong state."""


class InputError(LiberoDataError, ValueError):
    """A value the user chose is not acceptable; ``field`` names it (e.g. ``image_size``)."""

    def __init__(self, message: str, *, field: str | None = None) -> None:
        super().__init__(message)
        self.field = field


class ConfigError(InputError):
    """A config field out of range; the message is ``Class.field ...``."""


class UnknownNameError(LiberoDataError, KeyError):
    """An unknown name of something registered (an algorithm, a policy, a preset, a skill)."""

    def __str__(self) -> str:  # KeyError quotes its message; we want the sentence.
        return str(self.args[0])


class TaskLookupError(UnknownNameError):
    """An unknown suite or task; the message suggests the closest known names."""


class BDDLError(LiberoDataError, ValueError):
    """Malformed BDDL: the message names the file, the line and the problem."""

    def __init__(self, problem: str, *, source: str = "<string>", line: int | None = None) -> None:
        self.problem = problem
        self.source = source
        self.line = line
        where = source if line is None else f"{source}, line {line}"
        super().__init__(f"{where}: {problem}")


class MissingFileError(LiberoDataError, FileNotFoundError):
    """A file or folder the work needs does not exist."""

    def __str__(self) -> str:
        return str(self.args[0]) if self.args else ""


class FolderError(LiberoDataError, ValueError):
    """A folder holds something else than the work asked for (another dataset, other settings)."""


class SettingsChanged(FolderError):
    """A resumable folder was started with other settings; ``changed`` lists the keys that differ."""

    def __init__(self, message: str, *, changed: list[str]) -> None:
        super().__init__(message)
        self.changed = changed


class FolderBusy(FolderError):
    """Another process is working in the folder."""


class SceneError(LiberoDataError, RuntimeError):
    """A task's scene cannot be simulated: LIBERO cannot build it or place its objects."""


class RenderBackendError(LiberoDataError, RuntimeError):
    """No usable headless OpenGL backend (EGL or OSMesa)."""


class DatasetError(LiberoDataError, ValueError):
    """A dataset folder is not a dataset, or not one this tool can read."""


class ExecutorError(InputError):
    """The chosen way of running jobs (processes, Ray, a cluster address) is not available."""


class PolicyServerError(LiberoDataError, ConnectionError):
    """A policy server cannot be reached, answers with an error, too late or not at all."""


class RunError(LiberoDataError, ValueError):
    """A benchmark run cannot go on (a run folder of another run, a missing rollout, ...)."""


class CheckpointError(LiberoDataError, ValueError):
    """A checkpoint cannot be opened: not ours, damaged, of another policy, or a pickle we refuse."""


class PolicyFolderError(LiberoDataError, ValueError):
    """A LeRobot policy folder is damaged: its config, weights or processors cannot be read."""


class FileFormatError(LiberoDataError, ValueError):
    """A file we read is not in its format: not JSON, a JSON file without a field it needs, ..."""
