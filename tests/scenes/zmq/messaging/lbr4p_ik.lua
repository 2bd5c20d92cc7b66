--[[ Child script of "LBR4p" (ikMovementViaRemoteApi.xml), threaded. Two parts:

IK: an IK group that pulls the dummy "tip" onto the dummy "target" (position and orientation)
through the arm's 7 joints, solved every step (sysCall_actuation); the solution becomes the
joints' target positions, which their position control follows. Whatever moves "target" (a
client, the thread below) moves the tip.

Movements: simx's stand-in for the script of CoppeliaSim 4.3-4.5's
messaging/ikMovementViaRemoteApi.ttt, written from what its ZMQ remote API examples
(sendIkMovementSequence-mov.py, -pts.py) expect of it. The protocol:

  * signal: the string signal "/LBR4p_executedMovId" says "ready" once the thread runs, then
    the id of each movement when it has been executed.
  * remoteApi_getPoseAndConfig() returns the target's pose (world frame, [x y z qx qy qz qw])
    and the 7 joints' positions (rad).
  * remoteApi_movementDataFunction(data) stores a movement under data.id:
      {id, type='mov', targetPose, maxVel, maxAccel [, maxJerk]}: the target along a straight
        line (sim.moveToPose, metric 1, 1, 1, 0.1: 0.1 m per rad of turn; m/s, m/s^2, m/s^3,
        maxJerk default 80) to targetPose;
      {id, type='pts', times, x, y, z, qx, qy, qz, qw}: the target through the poses at the
        times (s from the movement's start; the quaternions normalised), linearly between
        them, one pose per simulation step.
  * remoteApi_executeMovement(id) queues the stored movement id (an error if none was
    stored); the thread executes queued movements one after the other. ]]

local METRIC = {1, 1, 1, 0.1}
local JERK = 80

function sysCall_init()
    local base = sim.getObject('.')
    tip, target = sim.getObject('./tip'), sim.getObject('./target')
    joints = sim.getObjectsInTree(base, sim.object_joint_type, 1)
    env = simIK.createEnvironment()
    group = simIK.createGroup(env)
    simIK.setGroupCalculation(env, group, simIK.method_damped_least_squares, 0.02, 20)
    simIK.addElementFromScene(env, group, base, tip, target, simIK.constraint_pose)
    signalName = '/' .. sim.getObjectAlias(base) .. '_executedMovId'
    movements, queue = {}, {}
end

function sysCall_actuation()
    simIK.handleGroup(env, group, {syncWorlds = true})
end

function remoteApi_getPoseAndConfig()
    local config = {}
    for i, joint in ipairs(joints) do config[i] = sim.getJointPosition(joint) end
    return sim.getObjectPose(target, -1), config
end

function remoteApi_movementDataFunction(data)
    if type(data) ~= 'table' or data.id == nil then
        error('remoteApi_movementDataFunction: expects a table with an id')
    end
    if data.type ~= 'mov' and data.type ~= 'pts' then
        error("remoteApi_movementDataFunction: type must be 'mov' or 'pts', got " .. tostring(data.type))
    end
    if data.type == 'mov' and (type(data.targetPose) ~= 'table' or #data.targetPose ~= 7) then
        error('remoteApi_movementDataFunction: targetPose must be 7 numbers (x y z qx qy qz qw)')
    end
    movements[data.id] = data
end

function remoteApi_executeMovement(id)
    if movements[id] == nil then
        error('remoteApi_executeMovement: no movement data with id ' .. tostring(id))
    end
    table.insert(queue, id)
end

local function executeMov(data)
    sim.moveToPose({
        object = target, targetPose = data.targetPose, metric = METRIC,
        maxVel = {data.maxVel}, maxAccel = {data.maxAccel}, maxJerk = {data.maxJerk or JERK},
    })
end

local function poseAt(data, k)
    local q = {data.qx[k], data.qy[k], data.qz[k], data.qw[k]}
    local n = math.sqrt(q[1] ^ 2 + q[2] ^ 2 + q[3] ^ 2 + q[4] ^ 2)
    return {data.x[k], data.y[k], data.z[k], q[1] / n, q[2] / n, q[3] / n, q[4] / n}
end

local function executePts(data)
    local times = data.times
    local t0, k = sim.getSimulationTime(), 1
    while true do
        local t = sim.getSimulationTime() - t0
        while k < #times and times[k + 1] <= t + 1e-9 do k = k + 1 end  -- a point due now, despite rounding
        local pose = poseAt(data, k)
        if k < #times and t > times[k] then
            pose = sim.interpolatePoses(pose, poseAt(data, k + 1), (t - times[k]) / (times[k + 1] - times[k]))
        end
        sim.setObjectPose(target, pose, -1)
        if k >= #times then return end
        sim.switchThread()
    end
end

function sysCall_thread()
    -- the thread yields where it says (sim.switchThread, a motion's steps) only: a point's
    -- targets are set together, never split by an automatic switch on a busy machine
    sim.setThreadAutomaticSwitch(false)
    sim.setStringSignal(signalName, 'ready')
    while true do
        if #queue > 0 then
            local id = table.remove(queue, 1)
            local data = movements[id]
            if data.type == 'mov' then executeMov(data) else executePts(data) end
            sim.setStringSignal(signalName, id)
        else
            sim.switchThread()
        end
    end
end
