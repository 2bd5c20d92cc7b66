-- The CoppeliaSim 4.x calls of the sim facade, one remote function each (tests/test_facade4.py
-- calls them with simxCallScriptFunction or Scripts.call); api.py is the same in Python.

function sysCall_init()
    sim.setInt32Signal('lua_init_state', sim.getSimulationState())
end

function sysCall_cleanup()
    print('cleanup state', sim.getSimulationState())
end

function relative(ints, floats, strings, buf)
    return {sim.getObject('./' .. strings[1], {noError = true})}
end

function signals(ints, floats, strings, buf)
    local name = strings[1]
    sim.setInt32Signal(name, ints[1])
    sim.setFloatSignal(name, floats[1])
    sim.setStringSignal(name, buf)
    local i, f, s = sim.getInt32Signal(name), sim.getFloatSignal(name), sim.getStringSignal(name)
    local old = sim.getIntegerSignal(name)  -- the 3.x name reads the same signal
    sim.clearInt32Signal(name)
    sim.clearFloatSignal(name)
    sim.clearStringSignal(name)
    local gone = (sim.getInt32Signal(name) == nil and sim.getFloatSignal(name) == nil
                  and sim.getStringSignal(name) == nil) and 1 or 0
    return {i, old, gone}, {f}, {}, s
end

function dummy(ints, floats, strings, buf)
    local h = sim.createDummy(floats[1])
    sim.setObjectPosition(h, -1, {floats[2], floats[3], floats[4]})
    sim.setObjectName(h, strings[1])
    return {h, sim.getObjectHandle(strings[1]), sim.getObject('/' .. strings[1])},
           sim.getObjectPosition(h, -1), {sim.getObjectAlias(h), sim.getObjectAlias(h, 1)}
end

function alias(ints, floats, strings, buf)
    sim.setObjectAlias(ints[1], strings[1])
    return {sim.getObject(sim.getObjectAlias(ints[1], 1))}, {}, {sim.getObjectAlias(ints[1])}
end

function parent(ints, floats, strings, buf)
    sim.setObjectParent(ints[1], ints[2], ints[3] == 1)
    return {sim.getObjectParent(ints[1])}, sim.getObjectPosition(ints[1], -1)
end

function getMatrix(ints, floats, strings, buf)
    return {}, sim.getObjectMatrix(ints[1], ints[2])
end

function setMatrix(ints, floats, strings, buf)
    if ints[2] == 1 then
        sim.setObjectMatrix(ints[1], floats)  -- CoppeliaSim 4.5's order, relative to the world
    else
        sim.setObjectMatrix(ints[1], -1, floats)
    end
    return {}, sim.getObjectMatrix(ints[1], -1)
end

function pose45(ints, floats, strings, buf)
    -- CoppeliaSim 4.5's argument order: value first, relativeTo last and optional
    sim.setObjectPosition(ints[1], {floats[1], floats[2], floats[3]})
    sim.setObjectOrientation(ints[1], {0, 0, floats[4]}, sim.handle_world)
    local p, o = sim.getObjectPosition(ints[1]), sim.getObjectOrientation(ints[1])
    return {}, {p[1], p[2], p[3], o[1], o[2], o[3]}
end

function velocity(ints, floats, strings, buf)
    local v, w = sim.getObjectVelocity(ints[1])
    return {}, {v[1], v[2], v[3], w[1], w[2], w[3]}
end

function tree(ints, floats, strings, buf)
    return sim.getObjectsInTree(ints[1], ints[2], ints[3])
end

function force(ints, floats, strings, buf)
    local a, b = {floats[1], floats[2], floats[3]}, {floats[4], floats[5], floats[6]}
    if ints[2] == 1 then sim.addForce(ints[1], a, b) else sim.addForceAndTorque(ints[1], a, b) end
end

function readForce(ints, floats, strings, buf)
    local r, f, t = sim.readForceSensor(ints[1])
    return {r}, {f[1], f[2], f[3], t[1], t[2], t[3]}
end

function readProx(ints, floats, strings, buf)
    local r, d, p, h, n = sim.readProximitySensor(ints[1])
    return {r, h}, {d, p[1], p[2], p[3], n[1], n[2], n[3]}
end

function image(ints, floats, strings, buf)
    local img, res = sim.getVisionSensorImg(ints[1], ints[2])
    local f = sim.getVisionSensorImage(ints[1])
    local g = sim.getVisionSensorImage(ints[1] + sim.handleflag_greyscale)
    return {res[1], res[2], #f, #g}, {f[1], f[2], f[3], g[1]}, {}, img
end

function params(ints, floats, strings, buf)
    -- ints: handle, int parameter, float parameter [, int value]; floats: [float value]
    local h, pid, fpid = ints[1], ints[2], ints[3]
    if #ints > 3 then sim.setObjectInt32Param(h, pid, ints[4]) end
    if #floats > 0 then sim.setObjectFloatParam(h, fpid, floats[1]) end
    local r, v = sim.getObjectInt32Parameter(h, pid)
    local fr, fv = sim.getObjectFloatParameter(h, fpid)
    local ur, uv = sim.getObjectInt32Parameter(h, 999999)  -- 3.x: result 0 for an unknown parameter
    return {sim.getObjectInt32Param(h, pid), r, v, fr, ur, uv}, {sim.getObjectFloatParam(h, fpid), fv}
end

function state(ints, floats, strings, buf)
    return {sim.getSimulationState(), sim.simulation_advancing_running, sim.simulation_paused,
            sim.simulation_stopped}
end

function unknown(ints, floats, strings, buf)
    sim.launchExecutable('console')
end
