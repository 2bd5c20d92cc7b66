-- simIK's chain calls from a Lua child script (tests/scripts/test_sim_ik_chains.py): the same
-- environment calls as the Python tests, CoppeliaSim 4.x style.

function sysCall_init()
    j1, j2, j3, j4 = sim.getObject('/j1'), sim.getObject('/j2'), sim.getObject('/j3'), sim.getObject('/j4')
    wrist, tip, target = sim.getObject('/wristJoint'), sim.getObject('/tip'), sim.getObject('/target')
    env = simIK.createEnvironment()
    group = simIK.createGroup(env)
    simIK.setGroupCalculation(env, group, simIK.method_damped_least_squares, 0.02, 200)
    simIK.addElementFromScene(env, group, -1, tip, target, simIK.constraint_position)
end

-- the Jacobian of the tip (a pose) and its error towards the target, in the configuration
-- floats = {q1, q2, q3, q4, alpha, beta, gamma (the wrist)}
function jacobian(ints, floats, strings, buf)
    simIK.setJointPosition(env, j1, floats[1])
    simIK.setJointPosition(env, j2, floats[2])
    simIK.setJointPosition(env, j3, floats[3])
    simIK.setJointPosition(env, j4, floats[4])
    simIK.setSphericalJointRotation(env, wrist, {floats[5], floats[6], floats[7]})
    local tipPose = simIK.getObjectPose(env, tip, -1)
    local targetPose = sim.getObjectPose(target, -1)
    local jac, err = simIK.computeJacobian(env, -1, wrist, simIK.constraint_pose, tipPose, targetPose)
    local out = {}
    for i = 1, #jac do out[#out + 1] = jac[i] end
    for i = 1, #err do out[#out + 1] = err[i] end
    return {#jac, #err}, out
end

-- j2 follows j1 (floats = {offset, mult}); solve towards the target, syncing the scene
function coupled(ints, floats, strings, buf)
    simIK.setJointDependency(env, j2, j1, floats[1], floats[2])
    local master, offset, mult = simIK.getJointDependency(env, j2)
    local result = simIK.handleGroup(env, group, {syncWorlds = true})
    local joints = simIK.getGroupJoints(env, group)
    return {result, #joints, master}, {simIK.getJointPosition(env, j1), simIK.getJointPosition(env, j2), offset, mult}
end

-- the environment saved to a buffer (a Lua string) and loaded into a new one, with a dummy of its own
function saved(ints, floats, strings, buf)
    local goal = simIK.createDummy(env, 'goal')
    simIK.setObjectPose(env, goal, {floats[1], floats[2], floats[3], 0, 0, 0, 1})
    local data = simIK.save(env)
    local copy = simIK.createEnvironment()
    simIK.load(copy, data)
    local pose = simIK.getObjectPose(copy, simIK.getObjectHandle(copy, 'goal'), -1)
    return {#data, simIK.getGroupHandle(copy, 'group' .. group)}, {pose[1], pose[2], pose[3]}, {type(data)}
end
