"""The 130 LIBERO tasks in five suites (plus ``libero_100``), and suites on disk.

>>> from libero_data.tasks import get_suite, get_task
>>> get_suite("libero_goal").tasks[0].language
'open the middle drawer of the cabinet'
>>> get_task("libero_10/3").name
"""

from libero_data.errors import TaskLookupError
from libero_data.tasks.suites import (
    SUITE_FILES,
    SUITE_MANIFEST,
    SUITE_NAMES,
    Suite,
    Task,
    get_suite,
    get_task,
    libero_root,
    task_order,
    task_orders,
)

__all__ = [
    "SUITE_FILES",
    "SUITE_MANIFEST",
    "SUITE_NAMES",
    "Suite",
    "Task",
    "TaskLookupError",
    "get_suite",
    "get_task",
    "libero_root",
    "task_order",
    "task_orders",
]
