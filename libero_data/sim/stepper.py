"""robosuite's control step, without the work that never changes its result.

A 20 Hz control step is 25 physics substeps. robosuite runs, per substep: ``mj_forward``,
the arm controller (which reads the arm's pose, Jacobians and mass matrix through
name lookups and small copies), the gripper's command ramp, ``mj_step``, and the
observables' clocks.

:class:`ControlStepper` runs the same computation with less around it:

- ``mj_step1`` / ``mj_step2`` instead of ``mj_forward`` + ``mj_step``. ``mj_step1`` computes
  the position and velocity stages (pose, Jacobians, mass matrix, bias forces: all the
  controller reads); the controller writes ``ctrl``; ``mj_step2`` computes the acceleration
  from it and integrates. This is MuJoCo's documented split of ``mj_step`` for controllers
  that read the state (Euler and implicit integrators), so one forward pass per substep
  disappears.
- The controller's state update reads through site, joint and actuator indices found once,
  with one Jacobian call for both halves, instead of name lookups on every substep.
- The arm's torques come from :class:`~libero_data.sim.osc.OperationalSpace`: robosuite's
  OSC equations evaluated with MuJoCo's linear algebra instead of NumPy's BLAS, whose kernel
  (and so the last bits of every torque) depends on the CPU. The same state and action give
  the same next state on any x86-64 machine.
- Torque limits and the gripper's control range are read once per model.
- robosuite's per-policy-step history buffers (recent torques, end-effector velocity and
  a smoothed acceleration) are not kept: nothing in LIBERO's tasks, the controller or the
  observations reads them.

The states follow LIBERO's own ``env.step`` to within the last bits of the controller's
arithmetic (tested). Only the Euler and implicit integrators allow the split; any other
model falls back to ``mj_forward`` + ``mj_step``.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from libero_data.sim.osc import OperationalSpace

# mjtIntegrator values for which mj_step1 + mj_step2 equals mj_step (MuJoCo's documentation:
# RK4 has no split form).
_SPLIT_INTEGRATORS = {0, 2, 3}  # Euler, implicit, implicitfast


class _Arm:
    """One robot arm with its controller and gripper, indexed once."""

    def __init__(self, robot: Any, mujoco: Any) -> None:
        sim = robot.sim
        model = sim.model
        self.robot = robot
        self.controller = robot.controller
        self.gripper = robot.gripper if robot.has_gripper else None
        self.control_dim = int(self.controller.control_dim)
        self.osc = OperationalSpace(self.controller)
        self.arm_ctrl = np.asarray(robot._ref_joint_actuator_indexes, dtype=np.intp)
        low, high = robot.torque_limits
        self.torque_low = np.array(low, copy=True)
        self.torque_high = np.array(high, copy=True)
        if self.gripper is not None:
            self.grip_ctrl = np.asarray(
                [model.actuator_name2id(a) for a in self.gripper.actuators], dtype=np.intp
            )
            ctrl_range = model.actuator_ctrlrange[self.grip_ctrl]
            self.grip_bias = 0.5 * (ctrl_range[:, 1] + ctrl_range[:, 0])
            self.grip_weight = 0.5 * (ctrl_range[:, 1] - ctrl_range[:, 0])
        self._install_update(sim, mujoco)

    def _install_update(self, sim: Any, mujoco: Any) -> None:
        """Give the controller an ``update`` that reads the state through cached indices.

        The values are those of robosuite's ``Controller.update`` (and the compatibility
        version that MuJoCo >= 3.4 needs), from the same MuJoCo calls; the end-effector
        velocity is a MuJoCo product instead of ``np.dot`` (BLAS). ``forward`` is passed as
        False while the stepper runs, where ``mj_step1`` has just brought the derived
        quantities up to date.
        """
        from robosuite.controllers.base_controller import Controller

        controller = self.controller
        model, data = sim.model._model, sim.data._data
        nv = int(model.nv)
        site = int(sim.model.site_name2id(controller.eef_name))
        qpos_index = np.asarray(controller.qpos_index, dtype=np.intp)
        qvel_index = np.asarray(controller.qvel_index, dtype=np.intp)
        # The compatibility update (MuJoCo >= 3.4) also clears the orientation reference.
        clears_ori_ref = getattr(Controller.update, "__name__", "") == "_modern_controller_update"
        mj_jac_site, mj_full_m, mj_forward = mujoco.mj_jacSite, mujoco.mj_fullM, mujoco.mj_forward
        mul_mat_vec = mujoco.mju_mulMatVec
        # MuJoCo 3.4 changed mj_fullM from (m, dst, qM) to (m, d, dst).
        modern_full_m = not hasattr(data, "qM")
        self.forward = True

        def update(force: bool = False) -> None:
            if not (controller.new_update or force):
                return
            if self.forward:
                mj_forward(model, data)
            controller.ee_pos = np.array(data.site_xpos[site])
            controller.ee_ori_mat = np.array(data.site_xmat[site].reshape([3, 3]))
            jacp = np.zeros((3, nv))
            jacr = np.zeros((3, nv))
            mj_jac_site(model, data, jacp, jacr, site)
            ee_pos_vel, ee_ori_vel = np.empty(3), np.empty(3)
            mul_mat_vec(ee_pos_vel, jacp, data.qvel)
            mul_mat_vec(ee_ori_vel, jacr, data.qvel)
            controller.ee_pos_vel, controller.ee_ori_vel = ee_pos_vel, ee_ori_vel
            controller.joint_pos = np.array(data.qpos[qpos_index])
            controller.joint_vel = np.array(data.qvel[qvel_index])
            controller.J_pos = np.array(jacp[:, qvel_index])
            controller.J_ori = np.array(jacr[:, qvel_index])
            controller.J_full = np.array(np.vstack([controller.J_pos, controller.J_ori]))
            mass_matrix: np.ndarray = np.ndarray(shape=(nv, nv), dtype=np.float64, order="C")
            if modern_full_m:
                mj_full_m(model, data, mass_matrix)
            else:
                mj_full_m(model, mass_matrix, data.qM)
            controller.mass_matrix = mass_matrix[qvel_index, :][:, qvel_index]
            controller.new_update = False
            if clears_ori_ref:
                controller.ori_ref = None

        controller.update = update

    def control(self, action: np.ndarray, ctrl: np.ndarray, policy_step: bool) -> None:
        """robosuite's ``SingleArm.control`` for OSC, less the history buffers."""
        controller = self.controller
        controller.update()
        if policy_step:
            self.osc.set_goal(action[: self.control_dim])
        torques = np.clip(self.osc.torques(), self.torque_low, self.torque_high)
        controller.new_update = True  # robosuite's run_controller ends so: re-read next substep
        self.robot.torques = torques
        if self.gripper is not None:
            grip = self.gripper.format_action(action[self.control_dim :])
            ctrl[self.grip_ctrl] = self.grip_bias + self.grip_weight * grip
        ctrl[self.arm_ctrl] = torques


class ControlStepper:
    """Steps one robosuite environment by whole control steps (see the module docstring).

    Built again whenever robosuite rebuilds its controllers (on every reset).
    """

    def __init__(self, env: Any) -> None:
        import mujoco

        self.env = env
        sim = env.sim
        self.model, self.data = sim.model._model, sim.data._data
        self.substeps = int(env.control_timestep / env.model_timestep)
        self.split = int(self.model.opt.integrator) in _SPLIT_INTEGRATORS
        self.arms = [_Arm(robot, mujoco) for robot in env.robots]
        self.cuts = np.cumsum([0] + [robot.action_dim for robot in env.robots])
        self._step1, self._step2, self._forward, self._step = (
            mujoco.mj_step1,
            mujoco.mj_step2,
            mujoco.mj_forward,
            mujoco.mj_step,
        )

    def step(self, action: np.ndarray) -> None:
        """One control step: robosuite's ``MujocoEnv.step`` without building observations."""
        env = self.env
        if env.done:
            raise ValueError("executing action in terminated episode")
        env.timestep += 1
        model, data = self.model, self.data
        ctrl = data.ctrl
        pieces = [action[a:b] for a, b in zip(self.cuts[:-1], self.cuts[1:], strict=True)]
        for arm in self.arms:
            arm.forward = False
        try:
            for i in range(self.substeps):
                if self.split:
                    self._step1(model, data)
                else:
                    self._forward(model, data)
                for arm, piece in zip(self.arms, pieces, strict=True):
                    arm.control(piece, ctrl, i == 0)
                if self.split:
                    self._step2(model, data)
                else:
                    self._step(model, data)
                env._update_observables()
        finally:
            for arm in self.arms:
                arm.forward = True
        env.cur_time += env.control_timestep
        env._post_action(action)


_RESTING_OPEN: dict[tuple[type, int, float], np.ndarray] = {}


def resting_open(gripper: Any) -> np.ndarray:
    """A fresh copy of the gripper's command ramp after a long stretch of "open" commands.

    Worked out once per gripper kind by running the ramp from zero (a few hundred small
    steps, which every restored state used to pay) and then copied, so the value is the
    same, bit for bit, as running it each time.
    """
    key = (type(gripper), int(gripper.dof), float(gripper.speed))
    value = _RESTING_OPEN.get(key)
    if value is None:
        saved = gripper.current_action
        gripper.current_action = np.zeros(gripper.dof)
        for _ in range(int(np.ceil(2.0 / gripper.speed)) + 1):
            gripper.format_action(np.array([-1.0]))
        value = _RESTING_OPEN[key] = np.array(gripper.current_action, copy=True)
        gripper.current_action = saved
    return value.copy()
