"""The legacy ``simx*`` functions on objects: handles, poses, joints, the object tree, model
properties, object parameters, collision and distance (re-exported by :mod:`simx_client.api`)."""

from __future__ import annotations

from simx_client.calls import _command
from simx_client.coercion import _bool, _f32, _f32_list, _float, _floats, _int, _str


# ----------------------------------------------------------------- objects
def simxGetObjectHandle(clientID, objectName, operationMode):
    """``(returnCode, handle)``; an unknown name gives 8 and handle 0, as V-REP did."""
    return _command(clientID, "GetObjectHandle", lambda: [_str(objectName)], operationMode, int, 0)


def simxGetObjects(clientID, objectType, operationMode):
    """``(returnCode, objectHandles)`` of a type (``sim_object_*_type``, or ``sim_handle_all``)."""
    return _command(clientID, "GetObjects", lambda: [_int(objectType)], operationMode, list, [])


def simxGetObjectPosition(clientID, objectHandle, relativeToObjectHandle, operationMode):
    """``(returnCode, [x, y, z])`` in m, relative to an object, -1 (world) or ``sim_handle_parent``."""
    return _command(clientID, "GetObjectPosition",
                    lambda: [_int(objectHandle), _int(relativeToObjectHandle)], operationMode, _f32_list, [0.0] * 3)


def simxGetObjectOrientation(clientID, objectHandle, relativeToObjectHandle, operationMode):
    """``(returnCode, [alpha, beta, gamma])`` in rad, R = Rx(alpha) Ry(beta) Rz(gamma)."""
    return _command(clientID, "GetObjectOrientation",
                    lambda: [_int(objectHandle), _int(relativeToObjectHandle)], operationMode, _f32_list, [0.0] * 3)


def simxGetObjectQuaternion(clientID, objectHandle, relativeToObjectHandle, operationMode):
    """``(returnCode, [x, y, z, w])``."""
    return _command(clientID, "GetObjectQuaternion",
                    lambda: [_int(objectHandle), _int(relativeToObjectHandle)], operationMode, _f32_list, [0.0] * 4)


# ------------------------------------------------------------------ joints
def simxGetJointPosition(clientID, jointHandle, operationMode):
    """``(returnCode, position)`` in rad (revolute) or m (prismatic)."""
    return _command(clientID, "GetJointPosition", lambda: [_int(jointHandle)], operationMode, _f32, 0.0)


def simxSetJointPosition(clientID, jointHandle, position, operationMode):
    """Teleport a joint to ``position`` (rad or m): returnCode."""
    return _command(clientID, "SetJointPosition", lambda: [_int(jointHandle), _f32(_float(position))],
                    operationMode)[0]


def simxSetJointTargetPosition(clientID, jointHandle, targetPosition, operationMode):
    """Target position of a joint's motor (rad or m), stored whatever the mode; it acts while the
    motor and its control loop are on (sim_jointintparam_motor_enabled 2000, ctrl_enabled 2001):
    returnCode."""
    return _command(clientID, "SetJointTargetPosition",
                    lambda: [_int(jointHandle), _f32(_float(targetPosition))], operationMode)[0]


def simxSetJointTargetVelocity(clientID, jointHandle, targetVelocity, operationMode):
    """Target velocity of a joint's motor (rad/s or m/s), stored whatever the mode; it acts while
    the motor is on and its control loop off (2000 on, 2001 off): returnCode."""
    return _command(clientID, "SetJointTargetVelocity",
                    lambda: [_int(jointHandle), _f32(_float(targetVelocity))], operationMode)[0]


def simxSetJointForce(clientID, jointHandle, force, operationMode):
    """Maximum force/torque of the joint's motor (N or N·m): returnCode."""
    return _command(clientID, "SetJointForce", lambda: [_int(jointHandle), _f32(_float(force))],
                    operationMode)[0]


def simxSetJointMaxForce(clientID, jointHandle, force, operationMode):
    """CoppeliaSim 4 name of :func:`simxSetJointForce`."""
    return simxSetJointForce(clientID, jointHandle, force, operationMode)


def simxGetJointForce(clientID, jointHandle, operationMode):
    """``(returnCode, force)``: force/torque the motor applies (N or N·m)."""
    return _command(clientID, "GetJointForce", lambda: [_int(jointHandle)], operationMode, _f32, 0.0)


def simxJointGetForce(clientID, jointHandle, operationMode):
    """Deprecated alias of :func:`simxGetJointForce`."""
    return simxGetJointForce(clientID, jointHandle, operationMode)


def simxGetJointMaxForce(clientID, jointHandle, operationMode):
    """``(returnCode, force)``: maximum force/torque of the motor (N or N·m)."""
    return _command(clientID, "GetJointMaxForce", lambda: [_int(jointHandle)], operationMode, _f32, 0.0)


# ----------------------------------------------------------- more of joints
def simxGetJointMatrix(clientID, jointHandle, operationMode):
    """``(returnCode, matrix)``: the joint's intrinsic transform, 12 floats (3x4, row-major)."""
    return _command(clientID, "GetJointMatrix", lambda: [_int(jointHandle)], operationMode, _f32_list, [0.0] * 12)


def simxSetSphericalJointMatrix(clientID, jointHandle, matrix, operationMode):
    """Set a spherical joint's intrinsic rotation from 12 floats (3x4, row-major): returnCode."""
    return _command(clientID, "SetSphericalJointMatrix",
                    lambda: [_int(jointHandle), _floats(matrix, 12)], operationMode)[0]


# ------------------------------------------------------------ tree and pose
def simxGetObjectChild(clientID, parentObjectHandle, childIndex, operationMode):
    """``(returnCode, childHandle)``: the child at ``childIndex`` (0-based), -1 when there is none."""
    return _command(clientID, "GetObjectChild", lambda: [_int(parentObjectHandle), _int(childIndex)],
                    operationMode, int, 0)


def simxGetObjectParent(clientID, childObjectHandle, operationMode):
    """``(returnCode, parentHandle)``: -1 when the object hangs from the world."""
    return _command(clientID, "GetObjectParent", lambda: [_int(childObjectHandle)], operationMode, int, 0)


def simxSetObjectPosition(clientID, objectHandle, relativeToObjectHandle, position, operationMode):
    """Move an object to ``position`` (3 floats, m) relative to an object / -1 / sim_handle_parent: returnCode."""
    return _command(clientID, "SetObjectPosition",
                    lambda: [_int(objectHandle), _int(relativeToObjectHandle), _floats(position, 3)], operationMode)[0]


def simxSetObjectOrientation(clientID, objectHandle, relativeToObjectHandle, eulerAngles, operationMode):
    """Set an object's Euler angles (alpha, beta, gamma in rad): returnCode."""
    return _command(clientID, "SetObjectOrientation",
                    lambda: [_int(objectHandle), _int(relativeToObjectHandle), _floats(eulerAngles, 3)],
                    operationMode)[0]


def simxSetObjectQuaternion(clientID, objectHandle, relativeToObjectHandle, quaternion, operationMode):
    """Set an object's orientation from a quaternion (x, y, z, w): returnCode."""
    return _command(clientID, "SetObjectQuaternion",
                    lambda: [_int(objectHandle), _int(relativeToObjectHandle), _floats(quaternion, 4)],
                    operationMode)[0]


def simxSetObjectParent(clientID, objectHandle, parentObject, keepInPlace, operationMode):
    """Attach an object (its body subtree) to another parent (-1: the world): returnCode."""
    return _command(clientID, "SetObjectParent",
                    lambda: [_int(objectHandle), _int(parentObject), _bool(keepInPlace)], operationMode)[0]


def simxGetObjectVelocity(clientID, objectHandle, operationMode):
    """``(returnCode, linearVelocity, angularVelocity)`` in the world frame (m/s, rad/s)."""
    rc, value = _command(clientID, "GetObjectVelocity", lambda: [_int(objectHandle)], operationMode,
                         lambda v: (_f32_list(v[0]), _f32_list(v[1])), None)
    return (rc, [0.0] * 3, [0.0] * 3) if value is None else (rc, *value)


def simxGetObjectGroupData(clientID, objectType, dataType, operationMode):
    """``(returnCode, handles, intData, floatData, stringData)`` for every object of a type."""
    rc, value = _command(clientID, "GetObjectGroupData", lambda: [_int(objectType), _int(dataType)],
                         operationMode, lambda v: (list(v[0]), list(v[1]), _f32_list(v[2]), list(v[3])), None)
    return (rc, [], [], [], []) if value is None else (rc, *value)


def simxGetObjectSelection(clientID, operationMode):
    """``(returnCode, objectHandles)`` selected (shared by all clients; no GUI)."""
    return _command(clientID, "GetObjectSelection", lambda: [], operationMode, list, [])


def simxSetObjectSelection(clientID, objectHandles, operationMode):
    """Replace the selection: returnCode."""
    return _command(clientID, "SetObjectSelection", lambda: [[_int(h) for h in objectHandles]], operationMode)[0]


def simxGetModelProperty(clientID, objectHandle, operationMode):
    """``(returnCode, prop)``: sim_modelproperty_* bits (0xf000: not a model)."""
    return _command(clientID, "GetModelProperty", lambda: [_int(objectHandle)], operationMode, int, 0)


def simxSetModelProperty(clientID, objectHandle, prop, operationMode):
    """Set model property bits: returnCode."""
    return _command(clientID, "SetModelProperty", lambda: [_int(objectHandle), _int(prop)], operationMode)[0]


# -------------------------------------------------------- object parameters
def simxGetObjectFloatParameter(clientID, objectHandle, parameterID, operationMode):
    """``(returnCode, parameterValue)`` (e.g. 1000/1001 near/far clipping in m)."""
    return _command(clientID, "GetObjectFloatParameter", lambda: [_int(objectHandle), _int(parameterID)],
                    operationMode, _f32, 0.0)


def simxSetObjectFloatParameter(clientID, objectHandle, parameterID, parameterValue, operationMode):
    """Set a float parameter of an object: returnCode."""
    return _command(clientID, "SetObjectFloatParameter",
                    lambda: [_int(objectHandle), _int(parameterID), _f32(_float(parameterValue))], operationMode)[0]


def simxGetObjectIntParameter(clientID, objectHandle, parameterID, operationMode):
    """``(returnCode, parameterValue)`` (e.g. 1002/1003 vision sensor resolution)."""
    return _command(clientID, "GetObjectIntParameter", lambda: [_int(objectHandle), _int(parameterID)],
                    operationMode, int, 0)


def simxSetObjectIntParameter(clientID, objectHandle, parameterID, parameterValue, operationMode):
    """Set an integer parameter of an object: returnCode."""
    return _command(clientID, "SetObjectIntParameter",
                    lambda: [_int(objectHandle), _int(parameterID), _int(parameterValue)], operationMode)[0]


simxGetObjectFloatParam = simxGetObjectFloatParameter
simxSetObjectFloatParam = simxSetObjectFloatParameter
simxGetObjectInt32Param = simxGetObjectIntParameter
simxSetObjectInt32Param = simxSetObjectIntParameter


# ------------------------------------------------- collision and distance
def simxGetCollisionHandle(clientID, collisionObjectName, operationMode):
    """``(returnCode, handle)`` of a collision object declared in the scene."""
    return _command(clientID, "GetCollisionHandle", lambda: [_str(collisionObjectName)], operationMode, int, 0)


def simxGetDistanceHandle(clientID, distanceObjectName, operationMode):
    """``(returnCode, handle)`` of a distance object declared in the scene."""
    return _command(clientID, "GetDistanceHandle", lambda: [_str(distanceObjectName)], operationMode, int, 0)


def simxGetCollectionHandle(clientID, collectionName, operationMode):
    """``(returnCode, handle)`` of a collection (simx scenes declare none: remote error)."""
    return _command(clientID, "GetCollectionHandle", lambda: [_str(collectionName)], operationMode, int, 0)


def simxReadCollision(clientID, collisionObjectHandle, operationMode):
    """``(returnCode, collisionState)`` of a collision object."""
    return _command(clientID, "ReadCollision", lambda: [_int(collisionObjectHandle)], operationMode, bool, False)


def simxReadDistance(clientID, distanceObjectHandle, operationMode):
    """``(returnCode, minimumDistance)`` (m) of a distance object."""
    return _command(clientID, "ReadDistance", lambda: [_int(distanceObjectHandle)], operationMode, _f32, 0.0)


def simxCheckCollision(clientID, entity1, entity2, operationMode):
    """``(returnCode, collisionState)`` between two objects (entity2 may be sim_handle_all)."""
    return _command(clientID, "CheckCollision", lambda: [_int(entity1), _int(entity2)], operationMode, bool, False)


def simxCheckDistance(clientID, entity1, entity2, operationMode):
    """``(returnCode, minimumDistance)`` (m) between two objects."""
    return _command(clientID, "CheckDistance", lambda: [_int(entity1), _int(entity2)], operationMode, _f32, 0.0)
