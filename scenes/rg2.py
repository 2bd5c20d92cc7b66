"""Child script of the RG2 gripper in Python: the example of a Python child script.

The shipped scene runs the same behaviour in Lua (scenes/rg2.lua); attach this file instead with
``child_script=rg2.py`` (docs/SCRIPTS.md). rg2Open / rg2Close drive RG2_openCloseJoint at
0.05 m/s with at most 20 N; remote programs call them with
simxCallScriptFunction('RG2', sim_scripttype_childscript, 'rg2Open', ...).
"""

motor_velocity = 0.05  # m/s
motor_force = 20.0  # N


def rg2Close(inInts, inFloats, inStrings, inBuffer):
    v = -motor_velocity
    sim.setJointForce(motor_handle, motor_force)
    sim.setJointTargetVelocity(motor_handle, v)
    return [], [v], [], b""


def rg2Open(inInts, inFloats, inStrings, inBuffer):
    v = motor_velocity
    sim.setJointForce(motor_handle, motor_force)
    sim.setJointTargetVelocity(motor_handle, v)
    return [], [v], [], b""


def sysCall_init():
    global motor_handle
    motor_handle = sim.getObjectHandle("RG2_openCloseJoint")
    rg2Open([], [], [], b"")
