-- Calls that never return (script_timeout=0.2 in the scene); fine() answers afterwards.
function spin(inInts, inFloats, inStrings, inBuffer)
    local i = 0
    while true do i = i + 1 end
end

function stubborn(inInts, inFloats, inStrings, inBuffer)
    while true do
        pcall(function() while true do end end)
    end
end

function inCoroutine(inInts, inFloats, inStrings, inBuffer)
    local co = coroutine.wrap(function() while true do end end)
    co()
end

function fine(inInts, inFloats, inStrings, inBuffer)
    return {7}
end
