"""Rotations and poses for the expert (matrices act on column vectors, world frame)."""

from __future__ import annotations

import numpy as np


def rot_z(angle: float) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def rot_axis(axis: np.ndarray, angle: float) -> np.ndarray:
    axis = np.asarray(axis, dtype=np.float64)
    axis = axis / np.linalg.norm(axis)
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + np.sin(angle) * k + (1 - np.cos(angle)) * (k @ k)


def log_rot(mat: np.ndarray) -> np.ndarray:
    """Axis-angle vector of a rotation matrix (angle in [0, pi])."""
    cos = np.clip((np.trace(mat) - 1.0) / 2.0, -1.0, 1.0)
    angle = float(np.arccos(cos))
    if angle < 1e-7:
        return np.zeros(3)
    if np.pi - angle < 1e-4:
        # Near pi: take the axis from the symmetric part.
        sym = (mat + np.eye(3)) / 2.0
        axis = np.sqrt(np.clip(np.diag(sym), 0.0, None))
        i = int(np.argmax(axis))
        axis = sym[:, i] / np.sqrt(max(sym[i, i], 1e-12))
        return axis / np.linalg.norm(axis) * angle
    vec = np.array([mat[2, 1] - mat[1, 2], mat[0, 2] - mat[2, 0], mat[1, 0] - mat[0, 1]])
    return vec / (2.0 * np.sin(angle)) * angle


def rotation_error(target: np.ndarray, current: np.ndarray) -> np.ndarray:
    """World-frame axis-angle taking ``current`` to ``target``."""
    return log_rot(target @ current.T)


def top_down(yaw: float) -> np.ndarray:
    """Gripper pointing straight down, fingers closing along ``(cos yaw, sin yaw, 0)``.

    Columns are the grip site's axes: x = closing direction, z = approach (down).
    """
    c, s = np.cos(yaw), np.sin(yaw)
    return np.array([[c, s, 0.0], [s, -c, 0.0], [0.0, 0.0, -1.0]])


def approach_frame(approach: np.ndarray, closing: np.ndarray) -> np.ndarray:
    """Gripper frame whose z axis points along ``approach`` and x axis along ``closing``."""
    z = np.asarray(approach, dtype=np.float64)
    z = z / np.linalg.norm(z)
    x = np.asarray(closing, dtype=np.float64)
    x = x - z * (x @ z)
    x = x / np.linalg.norm(x)
    y = np.cross(z, x)
    return np.stack([x, y, z], axis=1)


def yaw_of_closing(mat: np.ndarray) -> float:
    """Yaw of the gripper's closing axis projected on the table plane."""
    x = mat[:, 0]
    return float(np.arctan2(x[1], x[0]))


def wrap_half_turn(angle: float, reference: float) -> float:
    """The angle equivalent to ``angle`` modulo pi that is closest to ``reference``.

    A parallel gripper is symmetric under a half turn about its approach axis.
    """
    return reference + (angle - reference + np.pi / 2) % np.pi - np.pi / 2
