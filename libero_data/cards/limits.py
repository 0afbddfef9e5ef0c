"""Why the expert falls short on a task: stated reasons, kept as data (``expert_limits.json``:
task reference to one or two sentences), shown by the expert report beside every task whose
success within the standard limit is under its floor (:func:`within_floor`)."""

from __future__ import annotations

import functools
import json
from pathlib import Path

from libero_data.errors import FileFormatError

#: The reasons' file, in the package.
LIMITS_FILE = Path(__file__).with_name("expert_limits.json")
#: Success within the standard limit a task is held to (issue 74): every task of the five suites
#: 95% of its stored starts, a LIBERO-PRO or LIBERO-Plus task 80%, unless a reason is stated.
FIVE_SUITES_FLOOR = 0.95
OTHER_FLOOR = 0.80


def within_floor(suite: str) -> float:
    """The within-limit floor of a task of ``suite``."""
    from libero_data.tasks.suites import SUITE_NAMES

    return FIVE_SUITES_FLOOR if suite in SUITE_NAMES[:5] else OTHER_FLOOR


@functools.cache
def stated_reasons(path: Path = LIMITS_FILE) -> dict[str, str]:
    """{task reference: why the expert cannot do it within the limit} from ``path``."""
    try:
        data = json.loads(path.read_text())
    except (OSError, ValueError) as exc:
        raise FileFormatError(f"{path} is not a JSON object of task references and reasons ({exc})") from None
    if not isinstance(data, dict) or not all(
        isinstance(k, str) and isinstance(v, str) for k, v in data.items()
    ):
        raise FileFormatError(f"{path} is not a JSON object of task references and reasons")
    return dict(data)
