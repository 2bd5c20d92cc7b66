-- Issue 32's script programs in CoppeliaSim 4.x style (reach.py is the same in Python).

function sysCall_init()
    tip, target = sim.getObject('/tip'), sim.getObject('/target')
    link2, obstacle, eye = sim.getObject('/link2'), sim.getObject('/obstacle'), sim.getObject('/eye')
    env = simIK.createEnvironment()
    group = simIK.createGroup(env)
    simIK.setGroupCalculation(env, group, simIK.method_damped_least_squares, 0.05, 100)
    simIK.addElementFromScene(env, group, sim.getObject('/base'), tip, target, simIK.constraint_x + simIK.constraint_y)
    sim.setExplicitHandling(eye, 1)
end

-- move the target to (x, y) and solve: the arm's motors get the joint positions
function reach(ints, floats, strings, buf)
    sim.setObjectPosition(target, -1, {floats[1], floats[2], 0})
    local result = simIK.handleGroup(env, group, {syncWorlds = true})
    local joints = simIK.getGroupJoints(env, group)
    return {result, #joints}, {simIK.getJointPosition(env, joints[1]), simIK.getJointPosition(env, joints[2])}
end

function contact(ints, floats, strings, buf)
    local hit = sim.checkCollision(link2, obstacle)
    local r, data = sim.checkDistance(link2, obstacle)
    return {hit}, {data[7]}
end

-- the dark line's column in the camera image (-1: none), from an explicitly handled sensor
function see(ints, floats, strings, buf)
    sim.handleVisionSensor(eye)
    local r, packet = sim.readVisionSensor(eye)
    local img, res = sim.getVisionSensorImg(eye, 1)
    local best, col = 255, -1
    for x = 0, res[1] - 1 do
        local v = img:byte(math.floor(res[2] / 2) * res[1] + x + 1)
        if v < best then best, col = v, x end
    end
    return {col, res[1]}, {packet[11]}
end
