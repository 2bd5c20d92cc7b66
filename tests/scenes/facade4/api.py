# The CoppeliaSim 4.x calls of the sim facade in Python: api.lua's functions, with lists.


def sysCall_init():
    sim.setInt32Signal("py_init_state", sim.getSimulationState())


def sysCall_cleanup():
    print("cleanup state", sim.getSimulationState())


def relative(ints, floats, strings, buf):
    return [sim.getObject("./" + strings[0], {"noError": True})]


def signals(ints, floats, strings, buf):
    name = strings[0]
    sim.setInt32Signal(name, ints[0])
    sim.setFloatSignal(name, floats[0])
    sim.setStringSignal(name, buf)
    i, f, s = sim.getInt32Signal(name), sim.getFloatSignal(name), sim.getStringSignal(name)
    old = sim.getIntegerSignal(name)
    sim.clearInt32Signal(name)
    sim.clearFloatSignal(name)
    sim.clearStringSignal(name)
    gone = int(sim.getInt32Signal(name) is None and sim.getFloatSignal(name) is None
               and sim.getStringSignal(name) is None)
    return [i, old, gone], [f], [], s


def dummy(ints, floats, strings, buf):
    h = sim.createDummy(floats[0])
    sim.setObjectPosition(h, -1, floats[1:4])
    sim.setObjectName(h, strings[0])
    return ([h, sim.getObjectHandle(strings[0]), sim.getObject("/" + strings[0])],
            sim.getObjectPosition(h, -1), [sim.getObjectAlias(h), sim.getObjectAlias(h, 1)])


def alias(ints, floats, strings, buf):
    sim.setObjectAlias(ints[0], strings[0])
    return [sim.getObject(sim.getObjectAlias(ints[0], 1))], [], [sim.getObjectAlias(ints[0])]


def parent(ints, floats, strings, buf):
    sim.setObjectParent(ints[0], ints[1], ints[2] == 1)
    return [sim.getObjectParent(ints[0])], sim.getObjectPosition(ints[0], -1)


def getMatrix(ints, floats, strings, buf):
    return [], sim.getObjectMatrix(ints[0], ints[1])


def setMatrix(ints, floats, strings, buf):
    if ints[1] == 1:
        sim.setObjectMatrix(ints[0], floats)
    else:
        sim.setObjectMatrix(ints[0], -1, floats)
    return [], sim.getObjectMatrix(ints[0], -1)


def pose45(ints, floats, strings, buf):
    sim.setObjectPosition(ints[0], floats[0:3])
    sim.setObjectOrientation(ints[0], [0, 0, floats[3]], sim.handle_world)
    return [], sim.getObjectPosition(ints[0]) + sim.getObjectOrientation(ints[0])


def velocity(ints, floats, strings, buf):
    v, w = sim.getObjectVelocity(ints[0])
    return [], v + w


def tree(ints, floats, strings, buf):
    return sim.getObjectsInTree(ints[0], ints[1], ints[2])


def force(ints, floats, strings, buf):
    if ints[1] == 1:
        sim.addForce(ints[0], floats[0:3], floats[3:6])
    else:
        sim.addForceAndTorque(ints[0], floats[0:3], floats[3:6])


def readForce(ints, floats, strings, buf):
    r, f, t = sim.readForceSensor(ints[0])
    return [r], f + t


def readProx(ints, floats, strings, buf):
    r, d, p, h, n = sim.readProximitySensor(ints[0])
    return [r, h], [d, *p, *n]


def image(ints, floats, strings, buf):
    img, res = sim.getVisionSensorImg(ints[0], ints[1])
    f = sim.getVisionSensorImage(ints[0])
    g = sim.getVisionSensorImage(ints[0] + sim.handleflag_greyscale)
    return [res[0], res[1], len(f), len(g)], [f[0], f[1], f[2], g[0]], [], img


def params(ints, floats, strings, buf):
    h, pid, fpid = ints[0], ints[1], ints[2]
    if len(ints) > 3:
        sim.setObjectInt32Param(h, pid, ints[3])
    if floats:
        sim.setObjectFloatParam(h, fpid, floats[0])
    r, v = sim.getObjectInt32Parameter(h, pid)
    fr, fv = sim.getObjectFloatParameter(h, fpid)
    ur, uv = sim.getObjectInt32Parameter(h, 999999)
    return [sim.getObjectInt32Param(h, pid), r, v, fr, ur, uv], [sim.getObjectFloatParam(h, fpid), fv]


def state(ints, floats, strings, buf):
    return [sim.getSimulationState(), sim.simulation_advancing_running, sim.simulation_paused,
            sim.simulation_stopped]


def unknown(ints, floats, strings, buf):
    sim.launchExecutable("console")
