"""CoppeliaSim 4.x's model-library Lua modules that scenes ``require``, written here for simx from
what they do at run time: the conveyors (``require('conveyor_customization-2')`` in a conveyor
model's customization script, and the names later versions use).

CoppeliaSim's own modules (its ``lua/`` folder) build and edit a model in the GUI (paths,
shapes, dialogs) and drive it while the simulation runs; simx runs the second part on the model
as the scene saved it (its pads, rollers or forwarder already made), and does not rebuild a
model (a changed configuration is said once in the log).

A conveyor (``conveyor_customization-2``: a belt of pads along a closed path, or rollers;
``efficientConveyor_customization-2``: one static pad, the *forwarder*) is driven as
CoppeliaSim's module drives it:

* its configuration is the model's ``__config__`` custom table (``targetVel`` m/s, ``accel``
  m/s², ``type`` 1 belt or 2 rollers, the pads' ``beltElementThickness``, the rollers' ``radius``,
  m), CoppeliaSim's defaults for what it lacks;
* at each simulation step (``sysCall_actuation``) a table written to the model's ``__ctrl__``
  custom data (``sim.writeCustomTableData(model, '__ctrl__', {vel=v})`` or ``{pos=p}``, from any
  script or remote client; ``customData.__ctrl__`` as a 4.8 property) is taken and cleared: the
  belt moves toward velocity ``vel`` (m/s) with at most ``accel`` (Ruckig's velocity interface,
  ``sim.ruckigVel``, jerk unbounded), or to position ``pos`` (m along the path) and stops there
  (``sim.ruckigPos``); the belt's position and velocity are written to ``__state__``
  (``{pos=, vel=}``) and set back to 0 and the configured velocity when the simulation ends
  (``sysCall_afterSimulation``);
* the pads follow the path (the model's ``PATHCTRLPTS`` custom data, else ``PATH``: 7 numbers a
  point, position and quaternion in the model's frame; pads shifted outward by half their
  thickness, spaced evenly, each at ``(pos + i * spacing) mod length``), rollers turn to
  ``pos / radius``, and what lies on them is carried: CoppeliaSim's engines give a static shape
  moved by a script the velocity of its motion, and in simx each pad's (and roller's) surface
  moves at its velocity along the path (``sim.shapefloatparam_init_velocity_*``, the moving
  surfaces of :mod:`simx_server.sim.surfaces`); the forwarder of an efficient conveyor gets
  the belt's velocity along its own x axis, as CoppeliaSim's module sets it.

Its own module of the same name in the scene's folder wins, as ``require`` looks there first.
"""

from __future__ import annotations

__all__ = ["MODULES", "module_text"]

#: The conveyor's run-time part, shared by both kinds (``KIND`` is set before it).
_CONVEYOR = r"""
local KIND, host = ...
local sim = sim
local M = {}
local S = {pos = 0, vel = 0, prevPos = 0}
local DEFAULTS = {
  belt = {type = 1, length = 1, width = 0.2, radius = 0.1, rollerCnt = 16, beltElementWidth = 0.05,
          beltElementThickness = 0.005, beltElementSpacing = 0.002, targetVel = 0.1, accel = 0.01},
  efficient = {length = 1, width = 0.2, height = 0.1, targetVel = 0.1, accel = 0.01},
}
local SHAPE, JOINT, VEL = 0, 1, 3000  -- sim.object_shape_type, object_joint_type, shapefloatparam_init_velocity_x
local ANG_VEL = 3020  -- sim.shapefloatparam_init_ang_velocity_x

local function say(text) print("conveyor '" .. sim.getObjectAlias(S.model, 1) .. "': " .. text) end

local function modelHandle()
  local h = sim.getObject(".")
  if next(sim.readCustomTableData(h, "__config__")) == nil then  -- 4.6+: the script is the model's child
    local parent = sim.getObjectParent(h)
    if parent ~= -1 and next(sim.readCustomTableData(parent, "__config__")) ~= nil then h = parent end
  end
  return h
end

local function tagged(kind, tag)
  local out = {}
  for _, h in ipairs(sim.getObjectsInTree(S.model, kind, 1 + 2)) do
    local data = sim.readCustomDataBlock(h, tag)
    if data and #data > 0 then out[#out + 1] = h end
  end
  return out
end

-- The path: positions (3 a point) shifted outward by half the pads' thickness, quaternions
-- (x y z w), the cumulated lengths; closed.
local function readPath()
  local raw = sim.readCustomDataBlock(S.model, "PATHCTRLPTS")
  if not raw or #raw == 0 then raw = sim.readCustomDataBlock(S.model, "PATH") end
  if not raw or #raw < 8 * 14 then return false end
  local d = sim.unpackDoubleTable(raw)
  local n = #d // 7
  local first, last = 1, 7 * (n - 1) + 1
  local closed = true
  for k = 0, 2 do if math.abs(d[first + k] - d[last + k]) > 1e-9 then closed = false end end
  if not closed then for k = 0, 6 do d[#d + 1] = d[first + k] end n = n + 1 end
  local half = S.config.type == 1 and S.config.beltElementThickness / 2 or 0
  S.P, S.Q, S.L = {}, {}, {0}
  for i = 0, n - 1 do
    local x, y, z, w = d[7 * i + 4], d[7 * i + 5], d[7 * i + 6], d[7 * i + 7]
    local zx, zy, zz = 2 * (x * z + w * y), 2 * (y * z - w * x), 1 - 2 * (x * x + y * y)
    S.P[i + 1] = {d[7 * i + 1] + zx * half, d[7 * i + 2] + zy * half, d[7 * i + 3] + zz * half}
    S.Q[i + 1] = {x, y, z, w}
    if i > 0 then
      local a, b = S.P[i], S.P[i + 1]
      S.L[i + 1] = S.L[i] + math.sqrt((b[1] - a[1]) ^ 2 + (b[2] - a[2]) ^ 2 + (b[3] - a[3]) ^ 2)
    end
  end
  S.total = S.L[n]
  return S.total > 0
end

local function slerp(a, b, t)
  local dot = a[1] * b[1] + a[2] * b[2] + a[3] * b[3] + a[4] * b[4]
  local s = dot < 0 and -1 or 1
  dot = math.abs(dot)
  local wa, wb = 1 - t, t
  if dot < 0.9999 then
    local th = math.acos(dot)
    wa, wb = math.sin((1 - t) * th) / math.sin(th), math.sin(t * th) / math.sin(th)
  end
  local q = {wa * a[1] + s * wb * b[1], wa * a[2] + s * wb * b[2], wa * a[3] + s * wb * b[3], wa * a[4] + s * wb * b[4]}
  local m = math.sqrt(q[1] ^ 2 + q[2] ^ 2 + q[3] ^ 2 + q[4] ^ 2)
  return {q[1] / m, q[2] / m, q[3] / m, q[4] / m}
end

-- Pose at length p along the path (model frame) and the path's direction there.
local function atLength(p)
  local L = S.L
  local lo, hi = 1, #L
  while hi - lo > 1 do
    local mid = (lo + hi) // 2
    if L[mid] <= p then lo = mid else hi = mid end
  end
  local seg = L[hi] - L[lo]
  local t = seg > 0 and (p - L[lo]) / seg or 0
  local a, b = S.P[lo], S.P[hi]
  local pos = {a[1] + (b[1] - a[1]) * t, a[2] + (b[2] - a[2]) * t, a[3] + (b[3] - a[3]) * t}
  local dir = seg > 0 and {(b[1] - a[1]) / seg, (b[2] - a[2]) / seg, (b[3] - a[3]) / seg} or {0, 0, 0}
  return pos, slerp(S.Q[lo], S.Q[hi], t), dir
end

local function setVelocity(h, first, v)
  local last = S.lastVel[h]
  if last and math.abs(last[1] - v[1]) + math.abs(last[2] - v[2]) + math.abs(last[3] - v[3]) < 1e-12 then return end
  S.lastVel[h] = v
  for k = 1, 3 do sim.setObjectFloatParam(h, first + k - 1, v[k]) end
end

-- Every pad's pose and surface velocity, in one call to the host (one update of the scene).
local function placePads(p, vel)
  if not S.total then return end
  local poses, moved, vels = {}, {}, {}
  local m = sim.getObjectMatrix(S.model, -1)
  for i, h in ipairs(S.pads) do
    local at = (p + (i - 1) * S.padOffset) % S.total
    local pos, q, d = atLength(at)
    local k = 7 * (i - 1)
    poses[k + 1], poses[k + 2], poses[k + 3] = pos[1], pos[2], pos[3]
    poses[k + 4], poses[k + 5], poses[k + 6], poses[k + 7] = q[1], q[2], q[3], q[4]
    local v = {(m[1] * d[1] + m[2] * d[2] + m[3] * d[3]) * vel,  -- the path's direction, world axes
               (m[5] * d[1] + m[6] * d[2] + m[7] * d[3]) * vel, (m[9] * d[1] + m[10] * d[2] + m[11] * d[3]) * vel}
    local last = S.lastVel[h]
    if not last or math.abs(last[1] - v[1]) + math.abs(last[2] - v[2]) + math.abs(last[3] - v[3]) >= 1e-12 then
      S.lastVel[h] = v
      moved[#moved + 1] = h
      vels[#vels + 1], vels[#vels + 2], vels[#vels + 3] = v[1], v[2], v[3]
    end
  end
  local ok, err = host("poses", S.pads, poses, S.model, moved, vels)
  if not ok then error(err, 0) end
end

local function turnRollers(p, vel)
  local w = vel / S.config.radius
  for _, j in ipairs(S.rollers) do
    sim.setJointPosition(j, p / S.config.radius)
    local roller = sim.getObjectChild(j, 0)
    if roller ~= -1 then
      local m = sim.getObjectMatrix(j, -1)
      setVelocity(roller, ANG_VEL, {m[3] * w, m[7] * w, m[11] * w})
    end
  end
end

local function forward(vel)
  local m = sim.getObjectMatrix(S.forwarder, -1)
  sim.resetDynamicObject(S.forwarder)
  setVelocity(S.forwarder, VEL, {m[1] * vel, m[5] * vel, m[9] * vel})
end

local function move()
  if KIND == "efficient" then
    if S.forwarder then forward(S.vel) end
  elseif S.config.type == 2 then
    turnRollers(S.pos, S.vel)
  else
    placePads(S.pos, S.vel)
  end
end

local function writeState()
  sim.writeCustomTableData(S.model, "__state__", {pos = S.pos, vel = S.vel})
end

function M.init()
  S.model = modelHandle()
  local config = sim.readCustomTableData(S.model, "__config__")
  for k, v in pairs(DEFAULTS[KIND]) do if config[k] == nil then config[k] = v end end
  S.config = config
  S.pos, S.vel, S.prevPos = 0, 0, 0
  S.targetVel, S.targetPos = config.targetVel, nil
  S.lastVel = {}
  sim.writeCustomTableData(S.model, "__info__", {type = "conveyor", blocks = {
    __config__ = {type = "table"}, __ctrl__ = {type = "table"}, __state__ = {type = "table"}}})
  writeState()
  if KIND == "efficient" then
    for _, h in ipairs(sim.getObjectsInTree(S.model, SHAPE, 1)) do
      if sim.getObjectAlias(h) == "forwarder" then S.forwarder = h end
    end
    if not S.forwarder then say("no shape 'forwarder' in the model: nothing is carried") end
    return
  end
  S.pads, S.rollers = tagged(SHAPE, "PATHPAD"), tagged(JOINT, "PATHROL")
  if config.type == 2 then
    if #S.rollers == 0 then say("no rollers (joints with PATHROL data) in the model: nothing is carried") end
    return
  end
  if #S.pads == 0 then
    say("no pads (shapes with PATHPAD data) in the model: nothing is carried (simx does not rebuild a model)")
  elseif not readPath() then
    say("no path (PATHCTRLPTS or PATH data) in the model: its pads stay where they are")
    S.total = nil
  else
    S.padOffset = S.total / #S.pads
    placePads(0, 0)
  end
end
M.init2 = M.init

function M.actuation()
  local ctrl = sim.readCustomTableData(S.model, "__ctrl__")
  if next(ctrl) ~= nil then
    sim.writeCustomTableData(S.model, "__ctrl__", {})
    if ctrl.pos then S.targetPos, S.targetVel = ctrl.pos, nil end
    if ctrl.vel then S.targetVel, S.targetPos = ctrl.vel, nil end
  end
  local dt = sim.getSimulationTimeStep()
  local before, beforeVel = S.pos, S.vel
  if S.targetVel then
    local r = sim.ruckigVel(1, 0.0001, -1, {S.pos, S.vel, 0}, {S.config.accel, 99999}, {1}, {S.targetVel, 0})
    local result, state = sim.ruckigStep(r, dt)
    sim.ruckigRemove(r)
    if result == 0 then S.pos, S.vel = state[1], state[2]
    else S.vel = S.targetVel S.pos = S.pos + S.vel * dt end
  elseif S.targetPos then
    local r = sim.ruckigPos(1, 0.0001, -1, {S.pos, S.vel, 0}, {99999, S.config.accel, 99999}, {1}, {S.targetPos, 0})
    local result, state = sim.ruckigStep(r, dt)
    sim.ruckigRemove(r)
    if result == 0 then S.pos, S.vel = state[1], state[2]
    else S.vel, S.pos = 0, S.targetPos end
  end
  if before ~= S.pos or beforeVel ~= S.vel then
    move()
    writeState()
  end
end

function M.afterSimulation()
  S.pos, S.vel, S.prevPos = 0, 0, 0
  S.targetVel, S.targetPos = S.config.targetVel, nil
  S.lastVel = {}
  writeState()
end

_S = _S or {}
_S.conveyor = M
conveyor = M
function sysCall_init() M.init() end
function sysCall_actuation() M.actuation() end
function sysCall_afterSimulation() M.afterSimulation() end
return M
"""

#: ``require`` name -> the module's Lua text (a chunk that returns the module's table). Each
#: CoppeliaSim version's name for the conveyor modules.
MODULES = {
    **dict.fromkeys(("conveyor_customization", "conveyor_customization-2", "models.conveyor_customization-3",
                     "models.deprecated.conveyor_customization", "models.deprecated.conveyor_customization-2"),
                    "belt"),
    **dict.fromkeys(("efficientConveyor_customization-2", "models.efficientConveyor_customization-3",
                     "models.deprecated.efficientConveyor_customization-2"), "efficient"),
}


def module_text(name: str) -> str | None:
    """The Lua text of model-library module ``name`` (:data:`MODULES`), or None.

    Args:
        name: the name ``require`` was given.

    Returns:
        A chunk that defines the model's ``sysCall_*`` functions and returns its table.
    """
    kind = MODULES.get(name)
    if kind is None:
        return None
    return f"local host = ...\nreturn (function(...)\n{_CONVEYOR}\nend)({kind!r}, host)\n"
