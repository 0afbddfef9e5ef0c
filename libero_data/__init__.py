"""libero_data: LIBERO tasks, scripted demonstrations and LeRobot datasets.

Importing this package has no side effects: simulation, torch and lerobot are imported
only by the modules that need them, when they are used.
"""

__version__ = "0.1.0"
