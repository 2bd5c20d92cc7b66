"""Joints in V-REP's terms, as a mixin of :class:`simx_server.sim.world.World`: intrinsic
positions (``simxGetJointPosition``, ``simxSetJointPosition``), their motors' targets, maximum
forces and flags (``simxSetJointTargetPosition``, ``simxSetJointTargetVelocity``,
``simxSetJointForce``), and the force a joint exerts (``simxGetJointForce``). Positions in rad
(hinge) or m (slide), velocities in rad/s or m/s, forces in N·m or N. Joint motors themselves are
:mod:`simx_server.sim.motors`.
"""

from __future__ import annotations

import math

import mujoco

from simx_wire.protocol import ObjectTypeError
from simx_server.base import limits as L
from simx_server.sim import dyn_ctrl, physics
from simx_server.sim.objects import JOINT

# Bounds of the hot joint setters, as globals (one comparison each; see limits.py).
_MAX_Q, _MAX_V, _MAX_F = L.MAX_JOINT_POSITION, L.MAX_JOINT_VELOCITY, L.MAX_JOINT_FORCE


class Joints:
    """Joints of a :class:`~simx_server.sim.world.World` (needs its model, data, registry and motors)."""

    def _scalar_joint(self, handle: int) -> tuple[int, int]:
        """``(qpos address, dof address)`` of a hinge or slide joint (hot path: precomputed)."""
        addresses = self._scalar_joints.get(handle)
        if addresses is None:
            obj = self.get(handle, JOINT)  # raises for a handle that is not a joint
            raise ObjectTypeError(f"joint {obj.name!r} is spherical/free: use simxGetJointMatrix / "
                                  "simxSetSphericalJointMatrix")
        return addresses

    def refresh_cyclic(self) -> None:
        """Note which joints are cyclic: V-REP's revolute joints without limits (MuJoCo's hinges
        that are not ``limited``). Call after a change of ``jnt_limited``."""
        m = self.model
        hinge = int(mujoco.mjtJoint.mjJNT_HINGE)
        #: qpos addresses of the cyclic joints (:meth:`joint_position` reads them modulo 2 pi).
        self._cyclic_qadr = frozenset(q for h, (q, _) in self._scalar_joints.items()
                                      if int(m.jnt_type[self.objects[h].mj_id]) == hinge
                                      and not m.jnt_limited[self.objects[h].mj_id])

    def is_cyclic(self, handle: int) -> bool:
        """Whether joint ``handle`` is cyclic (a revolute joint without limits).

        Args:
            handle: a joint's handle.

        Returns:
            True for a cyclic joint; False for others (spherical joints included).
        """
        addresses = self._scalar_joints.get(handle)
        return addresses is not None and addresses[0] in self._cyclic_qadr

    def joint_position(self, handle: int) -> float:
        """Intrinsic position of a joint (rad or m). ``simxGetJointPosition``. A cyclic joint's
        is in [-pi, pi], as V-REP's physics engines report it (simDyn's
        ``CConstraintDyn_base::reportStateToCoppeliaSim``: ``atan2(sin a, cos a)``), however far
        it turned.

        Args:
            handle: a hinge or slide joint's handle.

        Returns:
            The position, rad or m.

        Raises:
            UnknownObjectError: no such object.
            ObjectTypeError: not a joint, or a spherical or free one.
        """
        qadr = self._scalar_joint(handle)[0]
        if qadr in self._cyclic_qadr:
            return math.remainder(self._qpos.item(qadr), math.tau)
        return self._qpos.item(qadr)

    def set_joint_position(self, handle: int, position: float) -> None:
        """Teleport a joint to ``position`` (rad or m) and hold it there. ``simxSetJointPosition``.

        Raises ArgumentError unless |position| <= limits.MAX_JOINT_POSITION.

        Args:
            handle: a hinge or slide joint's handle.
            position: rad or m.
        """
        qadr, dadr = self._scalar_joint(handle)
        if not -_MAX_Q <= position <= _MAX_Q:
            raise physics.out_of_range("joint position", position, -_MAX_Q, _MAX_Q, "rad or m", "MAX_JOINT_POSITION")
        self.data.qpos[qadr] = position
        self.data.qvel[dadr] = 0.0
        if handle in self.motor_index:
            self.target_position[self.motor_index[handle]] = (math.remainder(position, math.tau)
                                                              if qadr in self._cyclic_qadr else position)
            self.motors.teleported(self.motor_index[handle], position)  # a lock holds it here now
        self.changed()

    def set_joint_target_position(self, handle: int, position: float) -> None:
        """Target position of a joint's motor (rad or m), stored whatever the mode; it acts
        while the motor and its control loop are enabled. ``simxSetJointTargetPosition``. A
        cyclic joint's is kept in [-pi, pi] (``CJoint::setTargetPosition``: ``getNormalizedAngle``),
        and its position control takes the shortest way there (:mod:`simx_server.sim.motors`).

        Raises UnknownObjectError / ObjectTypeError (not a joint, spherical, driven through a
        tendon), ArgumentError unless |position| <= limits.MAX_JOINT_POSITION.

        Args:
            handle: a joint's handle.
            position: rad or m.
        """
        i = self.motor(handle)
        if not -_MAX_Q <= position <= _MAX_Q:
            raise physics.out_of_range("target position", position, -_MAX_Q, _MAX_Q, "rad or m", "MAX_JOINT_POSITION")
        if self.motors.qadr[i] in self._cyclic_qadr:
            position = math.remainder(position, math.tau)
        self.motors.target_position[i] = position

    def set_joint_target_velocity(self, handle: int, velocity: float) -> None:
        """Target velocity of a joint's motor (rad/s or m/s), stored whatever the mode; it acts
        while the motor is enabled and its control loop is not. ``simxSetJointTargetVelocity``.
        The signed target force turns to its sign (``CJoint::setTargetVelocity``).

        Raises as set_joint_target_position; ArgumentError unless |velocity| <=
        limits.MAX_JOINT_VELOCITY.

        Args:
            handle: a joint's handle.
            velocity: rad/s or m/s.
        """
        i = self.motor(handle)
        if not -_MAX_V <= velocity <= _MAX_V:
            raise physics.out_of_range("target velocity", velocity, -_MAX_V, _MAX_V, "rad/s or m/s",
                                       "MAX_JOINT_VELOCITY")
        dyn_ctrl.set_target_velocity(self.motors, i, velocity)

    def set_joint_force(self, handle: int, force: float, signed: bool = False) -> None:
        """Maximum force/torque of a joint's motor (N or N·m on the joint). ``simxSetJointForce``
        (the sign ignored: the target force takes the target velocity's); ``signed``:
        ``sim.setJointTargetForce``'s signed target force (:mod:`simx_server.sim.dyn_ctrl`: what
        CoppeliaSim 4.x's force mode applies; a target velocity of the other sign turns round).

        Raises ArgumentError unless |force| <= limits.MAX_JOINT_FORCE.

        Args:
            handle: a joint's handle.
            force: N or N·m.
            signed: keep the force's sign.
        """
        i = self.motor(handle)
        if not -_MAX_F <= force <= _MAX_F:
            raise physics.out_of_range("joint force", force, -_MAX_F, _MAX_F, "N or N·m", "MAX_JOINT_FORCE")
        dyn_ctrl.set_target_force(self.motors, i, float(force) if signed else abs(float(force)), signed)
        self.motors.write_force_limits(self.model)

    def joint_max_force(self, handle: int) -> float:
        """Maximum force/torque of a joint's motor (N or N·m).

        Args:
            handle: a joint's handle.

        Returns:
            N or N·m, >= 0.

        Raises:
            UnknownObjectError: no such object.
            ObjectTypeError: not a joint with a motor of its own.
        """
        return float(self.motors.max_force[self.motor(handle)])

    def set_motor_flags(self, handle: int, enabled: bool | None = None, loop: bool | None = None) -> None:
        """Motor on/off (``sim_jointintparam_motor_enabled``, 2000) and control loop on/off
        (``sim_jointintparam_ctrl_enabled``, 2001) of a joint. As in V-REP the targets are
        kept: turning the loop on drives the joint toward the stored target position. They
        leave CoppeliaSim 4.x's force and callback modes as its ``simSetObjectInt32Param`` does
        (:mod:`simx_server.sim.dyn_ctrl`): motor off is free, loop on from force mode is position
        control, loop off from callback mode is velocity control.

        Args:
            handle: a joint's handle.
            enabled: the motor on or off; None: unchanged.
            loop: the position control loop on or off; None: unchanged.

        Raises:
            UnknownObjectError: no such object.
            ObjectTypeError: not a joint with a motor of its own.
        """
        i = self.motor(handle)
        mo = self.motors
        if enabled is not None:
            mo.enabled[i] = enabled
        if loop is not None:
            mo.loop[i] = loop
        if mo.force_mode[i] or mo.callback_mode[i]:
            mo.force_mode[i] = mo.force_mode[i] and mo.enabled[i] and not mo.loop[i]
            mo.callback_mode[i] = mo.callback_mode[i] and mo.enabled[i] and bool(mo.loop[i])
            mo.refresh_flags()
            mo.write_force_limits(self.model)

    def joint_force(self, handle: int) -> float:
        """Force/torque the joint's motor applies now (N or N·m on the joint). ``simxGetJointForce``.

        Args:
            handle: a hinge or slide joint's handle.

        Returns:
            N or N·m: its motor's actuator force times the gear (a stopped velocity motor: the
            force of the velocity constraint that holds it, :mod:`simx_server.sim.motor_hold`), or
            for a joint without a motor the constraint force on its dof.

        Raises:
            UnknownObjectError: no such object.
            ObjectTypeError: not a joint, or a spherical or free one.
        """
        _, dadr = self._scalar_joint(handle)
        i = self.motors.index.get(handle)
        if i is not None:
            if self.motors.holds.held[i]:  # a stopped velocity motor: its joint's friction row
                return self.motors.holds.force(self.data, i)
            return float(self.data.actuator_force[self.motors.act[i]]) * float(self.motors.gear[i])
        return float(self.data.qfrc_constraint[dadr])
