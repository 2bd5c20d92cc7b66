--[[ remoteApiCommandServer: child script serving remote programs' scene edits (simx scene
ur5_ik.xml), in the style of the scene of visual-pushing-grasping.

    simxCallScriptFunction(clientID, 'remoteApiCommandServer', sim_scripttype_childscript,
        'importShape', {fileformat, options, ...}, {x, y, z, alpha, beta, gamma, r, g, b},
        {mesh_file, shape_name}, bytearray(), simx_opmode_blocking)

adds the mesh file (read by the server: .obj or .stl, fileformat 0 = by V-REP's codes, OBJ)
as a dynamic, respondable shape called shape_name at the given position (m) and Euler
angles (rad), both in the world frame, coloured r, g, b (0..1), and answers
({handle}, {}, {}, ''). Further ints are accepted and ignored.
]]

function importShape(inInts, inFloats, inStrings, inBuffer)
    local format = inInts[1] or 0
    local options = inInts[2] or 0
    local handle = sim.importShape(format, inStrings[1], options, 0, 1)
    if inStrings[2] and #inStrings[2] > 0 then
        sim.setObjectName(handle, inStrings[2])
    end
    -- dynamic and respondable, as V-REP scenes mark an imported shape (already so in simx)
    sim.setObjectInt32Param(handle, sim.shapeintparam_static, 0)
    sim.setObjectInt32Param(handle, sim.shapeintparam_respondable, 1)
    sim.setObjectPosition(handle, -1, {inFloats[1], inFloats[2], inFloats[3]})
    sim.setObjectOrientation(handle, -1, {inFloats[4], inFloats[5], inFloats[6]})
    if inFloats[9] then
        sim.setShapeColor(handle, nil, sim.colorcomponent_ambient_diffuse, {inFloats[7], inFloats[8], inFloats[9]})
    end
    return {handle}, {}, {}, ''
end
