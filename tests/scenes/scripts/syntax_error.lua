-- A Lua child script with a syntax error on line 4.
function ok() return {1} end

function broken( return {} end
