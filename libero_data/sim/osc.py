"""robosuite's OSC_POSE arm controller, evaluated without BLAS or LAPACK.

robosuite computes the operational-space torques with ``np.linalg.inv``, ``np.linalg.pinv``
and ``np.dot``. NumPy hands those to OpenBLAS, which picks a kernel for the CPU it runs on
(SkylakeX, Haswell, Sandybridge, ...), and each kernel adds up in its own order: the torques
of one state differ in the last bits from one machine to another. Measured on libero_90/42
(docs/reproducibility.md): the torques of the very first substep differ between the SkylakeX
and Haswell kernels (1.8e-15 N m, 5 of 7 joints), and by the end the expert's episode fails on
one kernel and succeeds on the other.

:class:`OperationalSpace` evaluates robosuite's equations with MuJoCo's own compiled linear
algebra (Cholesky factorisation and solves, matrix products) and element-wise NumPy arithmetic.
Neither looks at the CPU it runs on (MuJoCo's wheel has no runtime dispatch), so a state and an
action give the same torques on any x86-64 machine, whatever BLAS NumPy uses.

What differs from robosuite is the arithmetic, not the equations:

- ``M⁻¹ Jᵀ`` comes from solves with the Cholesky factor of the arm's mass matrix ``M`` instead
  of an explicit LU inverse.
- ``Λ = (J M⁻¹ Jᵀ)⁻¹`` and the inverses of its position and orientation blocks are applied
  to vectors by Cholesky solves instead of being formed as SVD pseudo-inverses. The matrices
  are symmetric positive definite wherever the arm's Jacobian has full rank, and both give the
  inverse; robosuite's cut-off (singular values below 1e-15 of the largest) only departs from
  it at an exact singularity, where the factorisation clamps the pivot instead.
- The nullspace term ``(I - J̄ J)ᵀ p`` (``J̄ = M⁻¹ Jᵀ Λ``) is evaluated as ``p - Jᵀ Λᵀ (M⁻¹ Jᵀ)ᵀ p``
  without forming the 7x7 matrix.
- The rotation of a delta action is built in float32, as robosuite's ``quat2mat`` does, with
  its sums in a fixed order.

For the same state, the torques agree with robosuite's to ~1e-14 of their size (tested).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

#: Pivots below this are clamped by the Cholesky factorisation (MuJoCo's own mjMINVAL).
_MINDIAG = 1e-15
#: robosuite's nullspace gains (``nullspace_torques``: joint_kp=10, critically damped).
_NULL_KP = 10.0
_NULL_KV = math.sqrt(_NULL_KP) * 2
#: robosuite's threshold below which a quaternion has no rotation (transform_utils.EPS).
_QUAT_EPS = float(np.finfo(float).eps) * 4.0


class UnsupportedController(ValueError):
    """The arm's controller is configured in a way this module does not implement."""


class OperationalSpace:
    """robosuite's ``OSC_POSE`` controller (delta actions, fixed impedance) for one arm.

    Reads and writes the robosuite controller's own attributes (``goal_pos``, ``goal_ori``,
    ``torques``, and the state its ``update`` fills in), so robosuite's resets keep working.
    """

    def __init__(self, controller: Any) -> None:
        import mujoco

        _check_supported(controller)
        self.controller = controller
        n = len(controller.qvel_index)
        self.kp = np.array(controller.kp, dtype=np.float64)
        self.kd = np.array(controller.kd, dtype=np.float64)
        self._chol = np.empty((n, n))
        self._minv_jt = np.empty((6, n))  # row k: M⁻¹ J[k], i.e. (M⁻¹ Jᵀ)ᵀ
        self._lam_inv = np.empty((6, 6))
        self._mj = mujoco

    def set_goal(self, delta: np.ndarray) -> None:
        """robosuite's ``OSC.set_goal`` for a delta action (the state is already updated)."""
        c = self.controller
        scaled = c.scale_action(delta)  # clip and scale: element-wise
        rot = [float(v) for v in scaled[3:6]]
        if any(not math.isclose(v, 0.0) for v in rot):
            goal_ori = np.empty((3, 3))
            self._mj.mju_mulMatMat(goal_ori, _delta_rotation(rot), c.ee_ori_mat)
            c.goal_ori = goal_ori
        c.goal_pos = c.ee_pos + scaled[:3]

    def torques(self) -> np.ndarray:
        """robosuite's ``OSC.run_controller`` (before torque limits), for the updated state."""
        mj, c = self._mj, self.controller
        jac, mass = c.J_full, c.mass_matrix
        chol, minv_jt, lam_inv = self._chol, self._minv_jt, self._lam_inv
        chol[:] = mass
        mj.mju_cholFactor(chol, _MINDIAG)
        for k in range(6):
            mj.mju_cholSolve(minv_jt[k], chol, jac[k])
        mj.mju_mulMatMatT(lam_inv, jac, minv_jt)  # Λ⁻¹ = J M⁻¹ Jᵀ
        # Λ and the inverses of its blocks are only ever applied to vectors: solve instead.
        lam_full = _factor(mj, lam_inv)
        lam_pos = _factor(mj, lam_inv[:3, :3])
        lam_ori = _factor(mj, lam_inv[3:, 3:])

        kp, kd = self.kp, self.kd
        force = np.multiply(c.goal_pos - c.ee_pos, kp[0:3]) + np.multiply(-c.ee_pos_vel, kd[0:3])
        ori_error = _orientation_error(c.goal_ori, c.ee_ori_mat)
        moment = np.multiply(ori_error, kp[3:6]) + np.multiply(-c.ee_ori_vel, kd[3:6])
        wrench = np.empty(6)
        mj.mju_cholSolve(wrench[:3], lam_pos, force)  # decoupled: Λ_pos f, Λ_ori τ
        mj.mju_cholSolve(wrench[3:], lam_ori, moment)
        n = mass.shape[0]
        torques = np.empty(n)
        mj.mju_mulMatTVec(torques, jac, wrench)
        torques += c.torque_compensation

        # Nullspace: hold the initial joint configuration, (I - J̄ J)ᵀ M (kp Δq - kv q̇), with
        # J̄ = M⁻¹ Jᵀ Λ and Λ symmetric: p - Jᵀ Λ (J M⁻¹ p).
        pose = np.empty(n)
        mj.mju_mulMatVec(pose, mass, _NULL_KP * (c.initial_joint - c.joint_pos) - _NULL_KV * c.joint_vel)
        proj, back, through = np.empty(6), np.empty(6), np.empty(n)
        mj.mju_mulMatVec(proj, minv_jt, pose)  # J M⁻¹ p
        mj.mju_cholSolve(back, lam_full, proj)  # Λ J M⁻¹ p
        mj.mju_mulMatTVec(through, jac, back)
        torques += pose - through
        c.torques = torques
        return torques


def _orientation_error(desired: np.ndarray, current: np.ndarray) -> np.ndarray:
    """robosuite's ``orientation_error``: half the sum of the columns' cross products.

    In Python floats, with the roundings of NumPy's ``cross`` (a product, a product, their
    difference) and the same order of sums: equal to robosuite's, bit for bit.
    """
    (c00, c01, c02), (c10, c11, c12), (c20, c21, c22) = current.tolist()
    (d00, d01, d02), (d10, d11, d12), (d20, d21, d22) = desired.tolist()
    ex = ((c10 * d20 - c20 * d10) + (c11 * d21 - c21 * d11)) + (c12 * d22 - c22 * d12)
    ey = ((c20 * d00 - c00 * d20) + (c21 * d01 - c01 * d21)) + (c22 * d02 - c02 * d22)
    ez = ((c00 * d10 - c10 * d00) + (c01 * d11 - c11 * d01)) + (c02 * d12 - c12 * d02)
    return np.array([0.5 * ex, 0.5 * ey, 0.5 * ez])


def _factor(mj: Any, matrix: np.ndarray) -> np.ndarray:
    """The Cholesky factor of a small symmetric positive definite matrix (for ``mju_cholSolve``)."""
    chol = np.array(matrix, dtype=np.float64, order="C")
    mj.mju_cholFactor(chol, _MINDIAG)
    return chol


def _delta_rotation(rot: list[float]) -> np.ndarray:
    """robosuite's ``quat2mat(axisangle2quat(rot))`` with its sums in a fixed order.

    LIBERO runs robosuite with Numba, and Numba's typing decides the arithmetic: the
    quaternion is rounded to float32 and scaled in float64 (then stored as float32), the
    diagonal is computed in float64 and the off-diagonal entries in float32. The same here.
    """
    x, y, z = rot
    angle = math.sqrt(x * x + y * y + z * z)
    if math.isclose(angle, 0.0):
        quat = (1.0, 0.0, 0.0, 0.0)
    else:
        half = np.float64(angle / 2.0)
        s = float(np.sin(half))
        quat = (float(np.cos(half)), x / angle * s, y / angle * s, z / angle * s)
    q = np.array(quat, dtype=np.float32)
    norm = float(((q[0] * q[0] + q[1] * q[1]) + q[2] * q[2]) + q[3] * q[3])
    if norm < _QUAT_EPS:
        return np.identity(3)
    q = (q.astype(np.float64) * math.sqrt(2.0 / norm)).astype(np.float32)
    q2 = np.multiply.outer(q, q)
    d = q2.astype(np.float64)
    return np.array(
        [
            [1.0 - d[2, 2] - d[3, 3], q2[1, 2] - q2[3, 0], q2[1, 3] + q2[2, 0]],
            [q2[1, 2] + q2[3, 0], 1.0 - d[1, 1] - d[3, 3], q2[2, 3] - q2[1, 0]],
            [q2[1, 3] - q2[2, 0], q2[2, 3] + q2[1, 0], 1.0 - d[1, 1] - d[2, 2]],
        ],
        dtype=np.float64,
    )


def _check_supported(controller: Any) -> None:
    """LIBERO's controller: OSC_POSE, delta actions, fixed impedance, no limits or interpolators."""
    checks = {
        "type OSC_POSE": type(controller).__name__ == "OperationalSpaceController"
        and getattr(controller, "use_ori", False),
        "delta actions": getattr(controller, "use_delta", False),
        "fixed impedance": getattr(controller, "impedance_mode", None) == "fixed",
        "uncoupled position and orientation": getattr(controller, "uncoupling", False),
        "no interpolators": getattr(controller, "interpolator_pos", None) is None
        and getattr(controller, "interpolator_ori", None) is None,
        "no position or orientation limits": getattr(controller, "position_limits", None) is None
        and getattr(controller, "orientation_limits", None) is None,
    }
    missing = [name for name, ok in checks.items() if not ok]
    if missing:
        raise UnsupportedController(
            f"the arm controller {type(controller).__name__} is not LIBERO's OSC_POSE configuration "
            f"(needs: {', '.join(missing)})"
        )
