-- A step counter written the CoppeliaSim 4.x way (issue 12's reproduction): a client waits for
-- the integer signal 'steps' with simxGetIntegerSignal (streaming, then buffer).
local n

function sysCall_init()
    n = 0
end

function sysCall_actuation()
    n = n + 1
    sim.setInt32Signal('steps', n)
end
