--[[ Child script of "blueArm" and "redArm" (movementViaRemoteApi.xml), threaded: simx's stand-in
for the scripts of CoppeliaSim 4.3-4.5's messaging/movementViaRemoteApi.ttt, written from what
its ZMQ remote API examples (sendMovementSequence-mov.py, -pts.py,
sendSimultan2MovementSequences-mov.py) expect of them. The protocol:

  * signal: the string signal "/<arm>_executedMovId" (e.g. "/blueArm_executedMovId") says
    "ready" once the thread runs, then the id of each movement when it has been executed.
  * remoteApi_movementDataFunction(data) stores a movement under data.id (a later one with the
    same id replaces it):
      {id, type='mov', targetConfig, targetVel, maxVel, maxAccel [, maxJerk]}: the first
        #targetConfig joints of the arm along a jerk-limited trajectory (sim.moveToConfig, rad,
        rad/s, rad/s^2; maxJerk defaults to 80 deg/s^3 per joint) to targetConfig, arriving
        with targetVel;
      {id, type='pts', times, j1, j2, ... jn}: joint k through the points jk at the times
        (s from the movement's start), linearly between them, one target per simulation step.
  * remoteApi_executeMovement(id) queues the stored movement id (an error if none was
    stored); the thread executes queued movements one after the other. A 'mov' that starts
    right after the previous one continues from that one's end velocity and acceleration
    (queued while the previous one ran); one that starts later starts at rest.

The joints are the arm's joints in tree order; the movements set their target positions, which
their position control follows. ]]

local JERK = 80 * math.pi / 180

function sysCall_init()
    local arm = sim.getObject('.')
    joints = sim.getObjectsInTree(arm, sim.object_joint_type, 1)
    signalName = '/' .. sim.getObjectAlias(arm) .. '_executedMovId'
    movements, queue = {}, {}
end

function remoteApi_movementDataFunction(data)
    if type(data) ~= 'table' or data.id == nil then
        error('remoteApi_movementDataFunction: expects a table with an id')
    end
    if data.type ~= 'mov' and data.type ~= 'pts' then
        error("remoteApi_movementDataFunction: type must be 'mov' or 'pts', got " .. tostring(data.type))
    end
    local n = data.type == 'mov' and #(data.targetConfig or {}) or 0
    if data.type == 'pts' then
        while data['j' .. (n + 1)] do n = n + 1 end
    end
    if n == 0 or n > #joints then
        error('remoteApi_movementDataFunction: movement ' .. tostring(data.id) .. ' moves ' .. n
              .. ' joints; the arm has ' .. #joints)
    end
    movements[data.id] = data
end

function remoteApi_executeMovement(id)
    if movements[id] == nil then
        error('remoteApi_executeMovement: no movement data with id ' .. tostring(id))
    end
    table.insert(queue, id)
end

local function filled(n, value)
    local t = {}
    for i = 1, n do t[i] = value end
    return t
end

local function executeMov(data, from)
    local n = #data.targetConfig
    local used = {}
    for i = 1, n do used[i] = joints[i] end
    local params = {
        joints = used, targetPos = data.targetConfig, targetVel = data.targetVel or filled(n, 0),
        maxVel = data.maxVel, maxAccel = data.maxAccel, maxJerk = data.maxJerk or filled(n, JERK),
    }
    if from and #from.pos == n then
        params.pos, params.vel, params.accel = from.pos, from.vel, from.accel
    end
    local res = sim.moveToConfig(params)
    return {pos = res.pos, vel = res.vel, accel = res.accel}
end

local function executePts(data)
    local times, columns = data.times, {}
    while data['j' .. (#columns + 1)] do columns[#columns + 1] = data['j' .. (#columns + 1)] end
    local t0, k = sim.getSimulationTime(), 1
    while true do
        local t = sim.getSimulationTime() - t0
        while k < #times and times[k + 1] <= t + 1e-9 do k = k + 1 end  -- a point due now, despite rounding
        local f = 0
        if k < #times and t > times[k] then f = (t - times[k]) / (times[k + 1] - times[k]) end
        for j, column in ipairs(columns) do
            local q = column[k]
            if k < #times then q = q + f * (column[k + 1] - q) end
            sim.setJointTargetPosition(joints[j], q)
        end
        if k >= #times then return end
        sim.switchThread()
    end
end

function sysCall_thread()
    -- the thread yields where it says (sim.switchThread, a motion's steps) only: a point's
    -- targets are set together, never split by an automatic switch on a busy machine
    sim.setThreadAutomaticSwitch(false)
    sim.setStringSignal(signalName, 'ready')
    local last = nil  -- the end state of the movement just executed, while the next one follows at once
    while true do
        if #queue > 0 then
            local id = table.remove(queue, 1)
            local data = movements[id]
            if data.type == 'mov' then
                last = executeMov(data, last)
            else
                executePts(data)
                last = nil
            end
            sim.setStringSignal(signalName, id)
        else
            last = nil
            sim.switchThread()
        end
    end
end
