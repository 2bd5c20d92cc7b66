--[[ Child script of "LBR4p" (ikMovementViaRemoteApi.xml): an IK group that pulls the dummy "tip"
onto the dummy "target" (position and orientation) through the arm's 7 joints, solved every step;
the solution becomes the joints' target positions, which their position control follows. ]]

function sysCall_init()
    local base = sim.getObject('.')
    tip, target = sim.getObject('./tip'), sim.getObject('./target')
    env = simIK.createEnvironment()
    group = simIK.createGroup(env)
    simIK.setGroupCalculation(env, group, simIK.method_damped_least_squares, 0.02, 20)
    simIK.addElementFromScene(env, group, base, tip, target, simIK.constraint_pose)
end

function sysCall_actuation()
    simIK.handleGroup(env, group, {syncWorlds = true})
end
