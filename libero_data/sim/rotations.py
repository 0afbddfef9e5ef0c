"""Small rotation helpers (quaternions in robosuite's x, y, z, w order)."""

from __future__ import annotations

import numpy as np


def quat_to_axis_angle(quat_xyzw: np.ndarray) -> np.ndarray:
    """Axis-angle vector (axis * angle, angle in [0, pi]) of a unit quaternion (x, y, z, w)."""
    q = np.asarray(quat_xyzw, dtype=np.float64)
    q = q / np.linalg.norm(q)
    if q[3] < 0:  # same rotation, angle in [0, pi]
        q = -q
    w = min(1.0, q[3])
    sin_half = np.sqrt(max(0.0, 1.0 - w * w))
    if sin_half < 1e-9:
        return np.zeros(3)
    angle = 2.0 * np.arccos(w)
    return q[:3] / sin_half * angle


def wxyz_to_xyzw(quat_wxyz: np.ndarray) -> np.ndarray:
    q = np.asarray(quat_wxyz)
    return np.array([q[1], q[2], q[3], q[0]])
