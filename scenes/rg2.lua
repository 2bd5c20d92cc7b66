--[[ OnRobot RG2 gripper: child script of the RG2 object (simx scene ur5_rg2_kinect.xml).

Remote programs open and close the gripper with
    simxCallScriptFunction(clientID, 'RG2', sim_scripttype_childscript, 'rg2Close', ...)
Both functions drive the fingers' joint RG2_openCloseJoint at SPEED m/s with at most
GRIP_FORCE N, so that closing on an object stops on it and holds it with that force, and
answer the velocity they set: ({}, {velocity}, {}, '').
The gripper opens when the simulation starts.
]]

local SPEED = 0.05      -- m/s, finger travel speed
local GRIP_FORCE = 20   -- N, most the motor pushes with
local fingers           -- handle of RG2_openCloseJoint

local function moveFingers(velocity)
    sim.setJointForce(fingers, GRIP_FORCE)
    sim.setJointTargetVelocity(fingers, velocity)
    return {}, {velocity}, {}, ''
end

function rg2Open(inInts, inFloats, inStrings, inBuffer)
    return moveFingers(SPEED)
end

function rg2Close(inInts, inFloats, inStrings, inBuffer)
    return moveFingers(-SPEED)
end

function sysCall_init()
    fingers = sim.getObjectHandle('RG2_openCloseJoint')
    moveFingers(SPEED)
end
