-- Child script of LuaBox (scripted.xml): functions called with sim.callScriptFunction over ZMQ.

function echo(...)
    return ...
end

function describe(t)
    local keys = {}
    for k, _ in pairs(t) do keys[#keys + 1] = k end
    table.sort(keys)
    return #keys, keys, sim.getObjectAlias(sim.getObject('.'))
end

function fail()
    error('failing on purpose')
end
