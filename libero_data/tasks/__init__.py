"""The 130 LIBERO tasks in five suites (plus ``libero_100``), the LIBERO-PRO suites installed with
them, and suites on disk.

>>> from libero_data.tasks import get_suite, get_task
>>> get_suite("libero_goal").tasks[0].language
'open the middle drawer of the cabinet'
>>> get_task("libero_10/3").name
"""

from libero_data.errors import TaskLookupError
from libero_data.tasks.suites import (
    SUITE_NAMES,
    ProSuite,
    get_suite,
    get_task,
    libero_root,
    pro_bases,
    pro_suite,
    pro_suite_names,
    suite_names,
    task_order,
    task_orders,
)
from libero_data.tasks.task import SUITE_FILES, SUITE_MANIFEST, Suite, Task

__all__ = [
    "SUITE_FILES",
    "SUITE_MANIFEST",
    "SUITE_NAMES",
    "ProSuite",
    "Suite",
    "Task",
    "TaskLookupError",
    "get_suite",
    "get_task",
    "libero_root",
    "pro_bases",
    "pro_suite",
    "pro_suite_names",
    "suite_names",
    "task_order",
    "task_orders",
]
