"""Joint commands: positions, motor targets, forces (``simxSetJointTargetVelocity``, ...), joint
matrices and object velocities (``simxGetJointMatrix``, ``simxGetObjectVelocity``). Every handler is
``(simulation, args) -> result``; the motor model is :mod:`simx_server.sim.motors`."""

from __future__ import annotations

from typing import Any, Callable

import mujoco
import numpy as np

from simx_wire.protocol import ArgumentError, ObjectTypeError
from simx_server.base.arguments import as_floats
from simx_server.base.arguments import check_args as _args
from simx_server.commands.handler import Handler
from simx_server.scene.simulation import Simulation
from simx_server.sim.kinematics import _BALL, joint_matrix, object_velocity
from simx_server.sim.world import JOINT


def get_joint_position(sim: Simulation, args: list) -> float:
    (h,) = _args(args, "int")
    return sim.world.joint_position(h)


def set_joint_position(sim: Simulation, args: list) -> None:
    h, v = _args(args, "int", "float")
    sim.world.set_joint_position(h, v)


def set_joint_target_position(sim: Simulation, args: list) -> None:
    h, v = _args(args, "int", "float")
    sim.world.set_joint_target_position(h, v)


def set_joint_target_velocity(sim: Simulation, args: list) -> None:
    h, v = _args(args, "int", "float")
    sim.world.set_joint_target_velocity(h, v)


def set_joint_force(sim: Simulation, args: list) -> None:
    h, v = _args(args, "int", "float")
    sim.world.set_joint_force(h, v)


def get_joint_force(sim: Simulation, args: list) -> float:
    (h,) = _args(args, "int")
    return sim.world.joint_force(h)


def get_joint_max_force(sim: Simulation, args: list) -> float:
    (h,) = _args(args, "int")
    return sim.world.joint_max_force(h)



def get_joint_matrix(sim: Simulation, args: list) -> list[float]:
    """``simxGetJointMatrix`` [h] -> 12 floats: the joint's intrinsic 3x4 transform, row-major
    (R00 R01 R02 tx R10 ... tz), m. See :func:`joint_matrix`."""
    (h,) = _args(args, "int")
    return joint_matrix(sim.world, h).reshape(12).tolist()


def set_spherical_joint_matrix(sim: Simulation, args: list) -> None:
    """``simxSetSphericalJointMatrix`` [h, [12 floats]] -> None.

    Sets a ball joint's rotation from the rotation part of a 3x4 row-major matrix (the
    translation column is ignored, as in V-REP) and zeroes its angular velocity. The 12 floats
    may also come flat ([h, m0, ..., m11]). Raises ObjectTypeError for other joints and
    ArgumentError for a matrix whose 3x3 part is not a rotation (tolerance 1e-3).
    """
    if len(args) == 13:
        args = [args[0], list(args[1:])]
    h, values = _args(args, "int", "any")
    world = sim.world
    obj = world.get(h, JOINT)
    m, d = world.model, world.data
    if int(m.jnt_type[obj.mj_id]) != _BALL:
        raise ObjectTypeError(f"joint {obj.name!r} is not a spherical (ball) joint: "
                              "use simxSetJointPosition for revolute and prismatic joints")
    rot = np.array(as_floats(values, 12, "matrix")).reshape(3, 4)[:, :3]
    if not np.allclose(rot.T @ rot, np.eye(3), atol=1e-3) or np.linalg.det(rot) < 0:
        raise ArgumentError("matrix: its 3x3 rotation part (elements 0-2, 4-6, 8-10) is not a "
                            "rotation matrix (orthonormal, determinant +1)")
    u, _, vt = np.linalg.svd(rot)  # nearest exact rotation
    quat = np.empty(4)
    mujoco.mju_mat2Quat(quat, (u @ vt).reshape(9))
    a, v = int(m.jnt_qposadr[obj.mj_id]), int(m.jnt_dofadr[obj.mj_id])
    d.qpos[a:a + 4] = quat / np.linalg.norm(quat)
    d.qvel[v:v + 3] = 0.0
    sim.world.changed()


def get_object_velocity(sim: Simulation, args: list) -> list[list[float]]:
    """``simxGetObjectVelocity`` [h] -> [[vx, vy, vz], [wx, wy, wz]] in the world frame (m/s,
    rad/s), of the object's origin; see :func:`object_velocity`."""
    (h,) = _args(args, "int")
    v, w = object_velocity(sim, h)
    return [v.tolist(), w.tolist()]


#: Command name -> handler, merged into simx_server.commands.HANDLERS.
KINEMATICS_HANDLERS: dict[str, Callable[[Simulation, list], Any]] = {
    "GetJointMatrix": get_joint_matrix,
    "SetSphericalJointMatrix": set_spherical_joint_matrix,
    "GetObjectVelocity": get_object_velocity,
}


#: Command name -> number of leading arguments that identify it (for protocol.COMMANDS).
KINEMATICS_IDENTITY_ARITY: dict[str, int] = {
    "GetJointMatrix": 1,
    "SetSphericalJointMatrix": 1,
    "GetObjectVelocity": 1,
}




#: Command name -> handler: joint positions, motor targets and forces.
JOINT_HANDLERS: dict[str, Handler] = {
    "GetJointPosition": get_joint_position,
    "SetJointPosition": set_joint_position,
    "SetJointTargetPosition": set_joint_target_position,
    "SetJointTargetVelocity": set_joint_target_velocity,
    "SetJointForce": set_joint_force,
    "GetJointForce": get_joint_force,
    "GetJointMaxForce": get_joint_max_force,
}
