"""Issue 32's script programs in CoppeliaSim 4.x style (reach.lua is the same in Lua)."""


def sysCall_init():
    global tip, target, link2, obstacle, eye, env, group
    tip, target = sim.getObject('/tip'), sim.getObject('/target')
    link2, obstacle, eye = sim.getObject('/link2'), sim.getObject('/obstacle'), sim.getObject('/eye')
    env = simIK.createEnvironment()
    group = simIK.createGroup(env)
    simIK.setGroupCalculation(env, group, simIK.method_damped_least_squares, 0.05, 100)
    simIK.addElementFromScene(env, group, sim.getObject('/base'), tip, target, simIK.constraint_x + simIK.constraint_y)
    sim.setExplicitHandling(eye, 1)


def reach(ints, floats, strings, buf):
    sim.setObjectPosition(target, -1, [floats[0], floats[1], 0])
    result, _, _ = simIK.handleGroup(env, group, {'syncWorlds': True})
    joints = simIK.getGroupJoints(env, group)
    return [result, len(joints)], [simIK.getJointPosition(env, j) for j in joints], [], b''


def contact(ints, floats, strings, buf):
    hit, _ = sim.checkCollision(link2, obstacle)
    _, data, _ = sim.checkDistance(link2, obstacle)
    return [hit], [data[6]], [], b''


def see(ints, floats, strings, buf):
    sim.handleVisionSensor(eye)
    _, packet = sim.readVisionSensor(eye)
    img, (w, h) = sim.getVisionSensorImg(eye, 1)
    row = img[(h // 2) * w:(h // 2) * w + w]
    col = min(range(w), key=lambda x: row[x])
    return [col, w], [packet[10]], [], b''
