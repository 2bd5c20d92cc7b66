--[[ Child script of "Cross" (synchronousImageTransmissionViaRemoteApi.xml): turns the cross at
SPEED rad/s from the start of the simulation. ]]

local SPEED = 1.0

function sysCall_init()
    local joint = sim.getObject('/CrossJoint')  -- the joint carries the cross: it is the cross's parent
    sim.setJointMaxForce(joint, 10)
    sim.setJointTargetVelocity(joint, SPEED)
end
