-- A healthy Lua child script: echoes its arguments, describes them and counts its inits.
function sysCall_init()
    sim.setIntegerSignal('lua_inits', (sim.getIntegerSignal('lua_inits') or 0) + 1)
end

function echo(inInts, inFloats, inStrings, inBuffer)
    return inInts, inFloats, inStrings, inBuffer
end

function describe(inInts, inFloats, inStrings, inBuffer)
    local upper = {}
    for i, s in ipairs(inStrings) do upper[i] = s:upper() end
    return {#inInts, #inFloats, #inStrings, #inBuffer},
           {sim.getSimulationTimeStep()},
           upper,
           sim.packFloatTable(inFloats)
end

-- Runs code sent by the client: refused unless the server runs with --allow-remote-code.
function executeCode(inInts, inFloats, inStrings, inBuffer)
    return {}, {}, {tostring(loadstring(inStrings[1])())}, ''
end
