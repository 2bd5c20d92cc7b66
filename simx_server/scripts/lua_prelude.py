"""The Lua code that prepares each Lua child script's state (:mod:`simx_server.scripts.lua`).

:data:`PRELUDE` is compiled once per script and called with the Python side's dispatcher, clock
check, log writer, the table's names and constants, the safety flags and the C-loop bounds of
:mod:`simx_server.scripts.lua_bounds`; it builds ``sim``/``simIK``, installs the count hook,
removes what the safety defaults forbid, and returns the lookup of the script's own functions and
the snapshot that ``sim.getUserVariables`` compares against, and the setter of a function the
count hook also calls (the threads' automatic switching, :mod:`simx_server.scripts.threads`).
"""

PRELUDE = r"""
local dispatch, expired, write_log, names, constants, allow_code, scene_dir, COUNT, FLAG, allow_unsafe, UNSAFE_FLAG, BOUNDS, read_module, model_module, model_host = ...
local G = _G
local sethook, gethook, getinfo, traceback = debug.sethook, debug.gethook, debug.getinfo, debug.traceback
local error, select, type, tostring, pairs, rawget, setmetatable = error, select, type, tostring, pairs, rawget, setmetatable
local pack, unpack, concat = table.pack, table.unpack, table.concat
local lua_load, cocreate, coresume = load, coroutine.create, coroutine.resume

-- Time bound: the hook runs every COUNT instructions; past the deadline it raises, and from then
-- on it runs (and raises) at every instruction, so that a pcall cannot swallow the interruption.
local TIMEOUT = "interrupted: the script did not return within its time bound (script_timeout)"
local hook, on_count
local function interrupt(level)
  sethook(hook, "", 1)
  error(TIMEOUT, level)
end
hook = function()
  if expired() then interrupt(3) end
  local _, _, count = gethook()
  if count ~= COUNT then sethook(hook, "", COUNT) end
  if on_count then on_count() end  -- last: threads' automatic switching may change the hook (threads.py)
end
sethook(hook, "", COUNT)
-- One instruction (a `..` of long strings) may copy much memory: the hook also runs at the next
-- instruction after each garbage-collection cycle, whose pace follows the bytes allocated (a
-- finalizer of simx's, which makes its successor; scripts cannot stop the collector).
local lua_setmetatable, lua_collect = setmetatable, collectgarbage
local function canary() lua_setmetatable({}, {__gc = function() sethook(hook, "", 1) canary() end}) end
canary()
G.collectgarbage = function(opt, ...)
  if opt == "stop" then return 0 end
  return lua_collect(opt, ...)
end
coroutine.create = function(f)
  local co = cocreate(f)
  sethook(co, hook, "", COUNT)
  return co
end
-- Lua runs hooks off while a hook runs, and the timeout is raised from inside the hook, so no
-- script code may run in the error's wake: an xpcall message handler is not called once the
-- deadline has passed (it would run with hooks off, forever if it loops), and a coroutine that
-- died of the timeout keeps hooks off for good (lua_resume leaves them so), so its pending
-- __close metamethods are not run by coroutine.close. A timeout inside a coroutine is raised
-- again in its resumer: coroutine.resume returning false would let the call go on and return as
-- if it had kept its bound.
local lua_xpcall, coclose = xpcall, coroutine.close
local timed_out = setmetatable({}, {__mode = "k"})
G.xpcall = function(f, handler, ...)
  if type(handler) ~= "function" then return lua_xpcall(f, handler, ...) end
  return lua_xpcall(f, function(m)
    if expired() then return m end
    return handler(m)
  end, ...)
end
local function resume(co, ...)
  local r = pack(coresume(co, ...))
  if not r[1] and expired() then
    timed_out[co] = true
    error(r[2], 0)  -- the coroutine's message (where in it the bound was reached); the resumer's hook does the rest
  end
  return unpack(r, 1, r.n)
end
coroutine.resume = resume
coroutine.close = function(co)
  if timed_out[co] then return false, TIMEOUT end
  return coclose(co)
end
coroutine.wrap = function(f)
  local co = coroutine.create(f)
  return function(...)
    local r = pack(resume(co, ...))
    if r[1] then return unpack(r, 2, r.n) end
    error(r[2], 0)
  end
end

-- The sim API. Its errors name the script's line: the first caller with a line number
-- (sim functions may be called through pcall or as tail calls).
local function where()
  for level = 3, 20 do
    local info = getinfo(level, "Sl")
    if not info then break end
    if info.currentline and info.currentline > 0 then
      return info.short_src .. ":" .. info.currentline .. ": "
    end
  end
  return ""
end
local sim = {}
local function bind(name)
  return function(...)
    local r = pack(dispatch(name, ...))
    if r[1] then return unpack(r, 2, r.n) end
    error(where() .. (name:find(".", 1, true) and "" or "sim.") .. name .. ": " .. tostring(r[2]), 0)
  end
end
-- simIK.NAME, simOMPL.NAME and simVision.NAME functions and constants come in the same lists, under
-- "simIK.", "simOMPL." and "simVision." names.
local simIK, simOMPL, simVision = {}, {}, {}
local libraries = {simIK = simIK, simOMPL = simOMPL, simVision = simVision}
local function library(name)
  local lib, short = name:match("^(sim%w+)%.(.+)$")
  if lib and libraries[lib] then return libraries[lib], short end
  return sim, name
end
for i = 1, #names do
  local lib, short = library(names[i])
  lib[short] = bind(names[i])
end
for k, v in pairs(constants) do
  local lib, short = library(k)
  lib[short] = v
end
setmetatable(sim, {__index = function(_, key)
  error(where() .. "sim." .. tostring(key) .. " is not available in simx (docs/SCRIPTS.md lists what is)", 0)
end})
G.sim = sim
setmetatable(simVision, {__index = function(_, key)
  error(where() .. "simVision." .. tostring(key) .. " is not available in simx (docs/SCRIPTS.md lists what is)", 0)
end})
-- CoppeliaSim 4.x's simIK (simx_server/api/simik/), simOMPL (simx_server/api/simompl/) and
-- simVision (simx_server/api/simvision/), as for ZMQ clients.
G.simIK, G.simOMPL, G.simVision = simIK, simOMPL, simVision
-- CoppeliaSim 4.5+ scripts start with `sim = require('sim')`: the same tables as modules
-- (CoppeliaSim's lua/sim.lua and the plugins' simIK.lua, simOMPL.lua return them), 'sim-1'/'sim-2' too.
package.loaded.sim, package.loaded["sim-1"], package.loaded["sim-2"], package.loaded.simIK = sim, sim, sim, simIK
package.loaded.simOMPL, package.loaded.simVision = simOMPL, simVision
-- CoppeliaSim's bundled model-customization modules (require('models.path_customization-2')...)
-- draw and edit a model in the GUI: headless, they load and each of their functions does nothing,
-- said once in the log; those that drive a model at run time (the conveyors) are simx's own
-- (simx_server/scripts/model_library.py), their chunk given the host's helpers. A script's own
-- module of the same name in the scene's folder wins.
setmetatable(package.preload, {__index = function(_, name)
  if type(name) ~= "string" or read_module(name, true) then
    return nil
  end
  local text = model_module(name)
  if text then
    local chunk = lua_load(text, "=simx:" .. name, "t")
    return function() return chunk(model_host) end
  end
  if not name:match("^models%.") then
    return nil
  end
  return function()
    write_log("require('" .. name .. "'): CoppeliaSim's bundled model-customization module; headless, "
      .. "its functions (the model's editing and drawing in the GUI) do nothing in simx")
    return setmetatable({}, {__index = function() return function() end end})
  end
end})
-- V-REP before 3.6: simGetObjectHandle(...), sim_handle_self.
setmetatable(G, {__index = function(_, key)
  if type(key) ~= "string" then return nil end
  local c = key:match("^sim_(.+)$")
  if c then return rawget(sim, c) end
  local f = key:match("^sim(%u.*)$")
  if f then return rawget(sim, f:sub(1, 1):lower() .. f:sub(2)) end
  return nil
end})

-- print goes to the server log.
G.print = function(...)
  local parts = {}
  for i = 1, select("#", ...) do parts[i] = tostring((select(i, ...))) end
  write_log(concat(parts, "\t"))
end

-- Lua 5.1 names that V-REP scripts use.
G.unpack = unpack
table.getn = function(t) return #t end
math.pow = function(x, y) return x ^ y end

-- C functions out of the count hook's reach (patterns, string.rep, table.sort...): lua_bounds.py.
BOUNDS(expired, interrupt)

-- Finalizers would run when the state is closed or collected, outside every time bound.
local lua_setmetatable = setmetatable
G.setmetatable = function(t, mt)
  if type(mt) == "table" and rawget(mt, "__gc") ~= nil then
    error("setmetatable: __gc finalizers are not available in simx child scripts (they would run "
      .. "outside the script's time bound, when its state is closed)", 2)
  end
  return lua_setmetatable(t, mt)
end

-- Safety.
local function refuse(name, why)
  return function() error(name .. " is not available in simx child scripts" .. (why or ""), 2) end
end
local REMOTE = ": simx runs code sent by clients only when the server is started with " .. FLAG
if allow_code then
  G.load = function(chunk, chunkname, mode, env)
    if env == nil then return lua_load(chunk, chunkname, "t") end
    return lua_load(chunk, chunkname, "t", env)
  end
  G.loadstring = function(s, chunkname) return lua_load(s, chunkname, "t") end
else
  G.load = refuse("load", REMOTE)
  G.loadstring = refuse("loadstring", REMOTE)
end
-- Files, processes and the environment (CoppeliaSim's "unsafe" functions): only with UNSAFE_FLAG.
local UNSAFE = ": file, process and environment functions need the server flag " .. UNSAFE_FLAG
local lua_loadfile, lua_searchpath = loadfile, package.searchpath
-- require reads Lua text only: a precompiled chunk can crash the Lua VM.
local function text_searcher(name)
  local file, err = lua_searchpath(name, package.path)
  if not file then return "\n\t" .. err end
  local chunk, lerr = lua_loadfile(file, "t")
  if not chunk then
    error(("error loading module '%s' from file '%s':\n\t%s"):format(name, file, lerr), 0)
  end
  return chunk, file
end
package.searchers[2] = text_searcher
package.searchers[3], package.searchers[4] = nil, nil  -- C libraries: never
if allow_unsafe then  -- plain Lua, but text chunks only (precompiled ones can crash the Lua VM)
  G.loadfile = function(file, mode, env)
    if env == nil then return lua_loadfile(file, "t") end
    return lua_loadfile(file, "t", env)
  end
  G.dofile = function(file)
    local f = assert(lua_loadfile(file, "t"))
    return f()
  end
else
  G.dofile = refuse("dofile", UNSAFE .. " (use require with a module in the scene's folder)")
  G.loadfile = refuse("loadfile", UNSAFE .. " (use require with a module in the scene's folder)")
  for _, name in ipairs({"open", "popen", "lines", "input", "output", "read", "write", "close", "tmpfile"}) do
    io[name] = refuse("io." .. name, UNSAFE)
  end
  io.stdin, io.stdout, io.stderr = nil, nil, nil  -- io.stdin:read() would block the simulation
  for _, name in ipairs({"execute", "remove", "rename", "tmpname", "getenv", "setlocale"}) do
    os[name] = refuse("os." .. name, UNSAFE)
  end
  package.loadlib = refuse("package.loadlib", UNSAFE)
  package.searchpath = refuse("package.searchpath", UNSAFE)
  -- require, without Lua's searchers: no script-visible table holds a function that reads files
  -- (package.searchers and package.loaders are empty, and the real ones are gone from this state),
  -- and no script code runs while anything that reads files is lent out (a preload loader once
  -- ran inside Lua's require with the real searchers in package.searchers: it took the file
  -- searcher, set package.path to any file and read /etc/passwd). The module's text is read by
  -- the host (read_module: a name of the scene's own folder, nothing else), then compiled here as
  -- text; package.path, cpath, searchers and preload are read from nowhere but the tables below.
  local LOADED, PRELOAD = package.loaded, package.preload
  package.searchers, package.loaders = {}, nil
  G.require = function(name)
    local kind = type(name)
    if kind == "number" then name = tostring(name)
    elseif kind ~= "string" then
      error("bad argument #1 to 'require' (string expected, got " .. (kind == "nil" and "no value" or kind) .. ")", 2)
    end
    local value = LOADED[name]
    if value then return value end
    local loader, extra = PRELOAD[name], ":preload:"
    if type(loader) ~= "function" then
      local text, where = read_module(name)
      if text == nil then
        error("module '" .. name .. "' not found:\n\tno field package.preload['" .. name .. "']\n\t" .. where, 2)
      end
      local chunk, err = lua_load(text, "@" .. where, "t")
      if not chunk then
        error(("error loading module '%s' from file '%s':\n\t%s"):format(name, where, err), 2)
      end
      loader, extra = chunk, where
    end
    value = loader(name, extra)
    if value ~= nil then LOADED[name] = value end
    if LOADED[name] == nil then LOADED[name] = true end
    return LOADED[name], extra
  end
end
os.exit = refuse("os.exit", " (it would end the server; simxStopSimulation stops the simulation)")
package.path = scene_dir .. "/?.lua"
package.cpath = ""
G.python = nil
package.loaded.python = nil
G.debug = {traceback = traceback, getinfo = getinfo}
package.loaded.debug = G.debug

-- Functions that can be called remotely: Lua functions the script defines as globals.
local base = {}
for k, v in pairs(G) do base[k] = v end
-- sim.getUserVariables as CoppeliaSim's sim.lua: the globals that were not there when the script's
-- own code began (snapshot() is called just before it), name -> value.
local initGlobals = base
sim.getUserVariables = function()
  local ng = {}
  for k, v in pairs(G) do if initGlobals[k] == nil then ng[k] = v end end
  ng.sim_call_type = nil
  return ng
end
local function snapshot()
  initGlobals = {}
  for k in pairs(G) do initGlobals[k] = true end
end
return function(name)
  local f = rawget(G, name)
  if type(f) == "function" and f ~= base[name] and getinfo(f, "S").what ~= "C" then return f end
  return nil
end, snapshot, function(f) on_count = f end
"""
