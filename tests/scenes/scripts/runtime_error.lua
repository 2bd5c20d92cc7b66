-- Run-time errors: a nil index (line 4) and a sim error (line 8); fine() keeps working.
function fail(inInts, inFloats, inStrings, inBuffer)
    local t = nil
    return {t.x}
end

function badObject(inInts, inFloats, inStrings, inBuffer)
    sim.getObjectHandle('no_such_object')
end

function unknownSim(inInts, inFloats, inStrings, inBuffer)
    sim.noSuchFunction(1)
end

function badReturn(inInts, inFloats, inStrings, inBuffer)
    return {'not an int'}
end

function fine(inInts, inFloats, inStrings, inBuffer)
    return {42}
end
