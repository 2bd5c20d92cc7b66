"""Lua child-script sandbox (issue 11, defect 14): CoppeliaSim's "unsafe" functions are off
unless the server runs with ``--allow-unsafe-lua``.

A child script in a test scene tries each unsafe function in ``sysCall_init`` and reports, in
the string signal ``sandbox``, which worked (``name=ok``) and which raised (``name=no``):

* in-process without the flag, every one fails with an error that names the flag, no file
  outside the scene's folder is read, written, removed or renamed, and ``require`` finds modules
  only in the scene's folder whatever the script does to ``package.path``/``cpath``/``searchers``;
* a real ``simx-server --allow-unsafe-lua`` gives them back (the client reads the signal with
  ``simxGetStringSignal``), while ``load`` still needs ``--allow-remote-code``.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from conftest import ServerProcess
from simx_client.protocol import ScriptError
from simx_server.scene.simulation import Simulation

pytestmark = pytest.mark.renderers_on_demand  # no image is read from an in-process Simulation here

SCENE = """<mujoco model="sandbox test">
  <worldbody>
    <body name="Box" pos="0 0 0.1"><geom type="box" size="0.01 0.01 0.01"/></body>
  </worldbody>
  <custom><text name="simx:Box" data="child_script=sandbox.lua"/></custom>
</mujoco>
"""

# Each attempt is a function that raises when the sandbox refuses it.
SANDBOX = r"""
local OUT = OUTSIDE
local attempts = {
  {"io.open.read", function() local f = assert(io.open(OUT .. "/secret.txt", "r")); local s = f:read("a"); f:close(); assert(s == "secret") end},
  {"io.open.write", function() local f = assert(io.open(OUT .. "/written.txt", "w")); f:write("x"); f:close() end},
  {"io.lines", function() for line in io.lines(OUT .. "/secret.txt") do end end},
  {"io.popen", function() local p = assert(io.popen("echo hi")); p:close() end},
  {"io.stdin", function() assert(io.stdin ~= nil) end},
  {"os.execute", function() assert(os.execute("exit 0")) end},
  {"os.remove", function() assert(os.remove(OUT .. "/doomed.txt")) end},
  {"os.rename", function() assert(os.rename(OUT .. "/moved.txt", OUT .. "/renamed.txt")) end},
  {"os.tmpname", function() assert(os.tmpname()) end},
  {"os.getenv", function() assert(os.getenv("PATH")) end},
  {"dofile", function() assert(dofile(OUT .. "/evil.lua") == "evil") end},
  {"loadfile", function() assert(loadfile(OUT .. "/evil.lua")() == "evil") end},
  {"package.path", function() package.path = OUT .. "/?.lua"; assert(require("evil") == "evil") end},
  {"package.searchers", function()
     package.path = OUT .. "/?.lua"
     local loader, file = package.searchers[2]("evil")
     assert(type(loader) == "function" and loader("evil", file) == "evil") end},
  {"package.loadlib", function() assert(package.loadlib("libc.so.6", "*")) end},
  {"package.searchpath", function() assert(package.searchpath("secret", OUT .. "/?.txt")) end},
  {"load", function() assert(load("return 1")() == 1) end},
}
local report = {}
for _, a in ipairs(attempts) do
  local ok, err = pcall(a[2])
  report[#report + 1] = a[1] .. "=" .. (ok and "ok" or "no")
end
sim.setStringSignal("sandbox", table.concat(report, " "))

-- A module of the scene's own folder still loads.
local helper = require("helper")
function helperValue() return {helper.value} end
function failure(inInts, inFloats, inStrings) local f = io.open(inStrings[1]) end
"""


def sandbox_scene(tmp_path: Path) -> tuple[Path, Path]:
    """The scene (in ``tmp_path/scene``) and the folder outside it that the script attacks."""
    scene_dir, outside = tmp_path / "scene", tmp_path / "outside"
    scene_dir.mkdir()
    outside.mkdir()
    (outside / "secret.txt").write_text("secret")
    (outside / "doomed.txt").write_text("x")
    (outside / "moved.txt").write_text("x")
    (outside / "evil.lua").write_text('return "evil"\n')
    (scene_dir / "helper.lua").write_text("return {value = 42}\n")
    (scene_dir / "sandbox.lua").write_text(SANDBOX.replace("OUTSIDE", json.dumps(str(outside)), 1))
    (scene_dir / "scene.xml").write_text(SCENE)
    return scene_dir / "scene.xml", outside


def report(text: str | bytes | bytearray) -> dict[str, str]:
    text = text if isinstance(text, str) else bytes(text).decode()
    return dict(item.split("=") for item in text.split())


UNSAFE = ["io.open.read", "io.open.write", "io.lines", "io.popen", "io.stdin", "os.execute", "os.remove",
          "os.rename", "os.tmpname", "os.getenv", "dofile", "loadfile", "package.path", "package.loadlib",
          "package.searchpath", "package.searchers"]


def test_unsafe_lua_functions_are_refused_by_default(tmp_path):
    scene, outside = sandbox_scene(tmp_path)
    sim = Simulation(scene, realtime=False)
    try:
        sim.start()
        got = report(sim.signals.get_string("sandbox"))
        assert got == {**{name: "no" for name in UNSAFE}, "load": "no"}
        assert sorted(p.name for p in outside.iterdir()) == ["doomed.txt", "evil.lua", "moved.txt", "secret.txt"]
        # require still works for the scene's own modules.
        assert sim.scripts.call("Box", 1, "helperValue", [], [], [], b"") == [[42], [], [], b""]
        # The error names the function and the flag that would allow it.
        with pytest.raises(ScriptError, match=r"sandbox\.lua:\d+: io\.open is not available in simx child "
                                              r"scripts: .* --allow-unsafe-lua"):
            sim.scripts.call("Box", 1, "failure", [], [], [str(outside / "secret.txt")], b"")
    finally:
        sim.close()


def test_allow_unsafe_lua_flag_gives_them_back(tmp_path):
    import vrep

    scene, outside = sandbox_scene(tmp_path)
    server = ServerProcess(str(scene), "--allow-unsafe-lua", renderers="on-demand")
    cid = -1
    try:
        cid = vrep.simxStart("127.0.0.1", server.port, True, True, 5000, 5)
        assert cid >= 0
        rc, text = vrep.simxGetStringSignal(cid, "sandbox", vrep.simx_opmode_blocking)
        assert rc == 0
        got = report(text)
        # load needs --allow-remote-code; lupa's Lua is built without io.popen ('popen' not supported).
        assert got == {**{name: "ok" for name in UNSAFE}, "load": "no", "io.popen": "no"}
        assert sorted(p.name for p in outside.iterdir()) == ["evil.lua", "renamed.txt", "secret.txt", "written.txt"]
    finally:
        if cid >= 0:
            vrep.simxFinish(cid)
        log = server.stop()
    assert "Lua child scripts may use files, processes and the environment (--allow-unsafe-lua)" in log


# Issue 57: with --allow-remote-code, a client scene's script took Lua's file searcher while
# require ran (it sat in package.searchers, and a package.preload loader is script code run in
# that window), set package.path to any file and read it. Each attack reports "stolen" when it
# got a file's text from outside the scene's folder, or a function that reads files.
REQUIRE_ATTACKS = r"""
local OUT = OUTSIDE
local stolen = {}
local function reads(f)  -- whether f, a searcher or a loader, reads a file outside the folder
  if type(f) ~= "function" or debug.getinfo(f, "S").source == "@sandbox.lua" then return false end
  package.path = OUT .. "/?.lua"
  local ok, loader, file = pcall(f, "evil")
  if ok and type(loader) == "function" then
    local ok2, v = pcall(loader, "evil", file)
    if ok2 and v == "evil" then return true end
  end
  return ok and loader == "evil"
end
local function note(name, got) stolen[#stolen + 1] = name .. "=" .. (got and "stolen" or "safe") end
local attacks = {
  preload_window = function()
    local grabbed = {}
    package.preload.grab = function()
      for _, t in ipairs({package.searchers or {}, package.loaders or {}}) do
        for _, f in pairs(t) do grabbed[#grabbed + 1] = f end
      end
      for level = 1, 12 do
        local info = debug.getinfo(level, "f")
        if info then grabbed[#grabbed + 1] = info.func end
      end
      return {}
    end
    require("grab")
    for _, f in ipairs(grabbed) do if reads(f) then return true end end
    return false
  end,
  searchers_now = function()
    for _, t in ipairs({package.searchers or {}, package.loaders or {}}) do
      for _, f in pairs(t) do if reads(f) then return true end end
    end
    return false
  end,
  package_newindex = function()
    local grabbed
    package.searchers, package.loaders = nil, nil
    setmetatable(package, {__newindex = function(t, k, v) rawset(t, k, v) grabbed = grabbed or v end})
    pcall(require, "helper")
    setmetatable(package, nil)
    if type(grabbed) == "table" then for _, f in pairs(grabbed) do if reads(f) then return true end end end
    return false
  end,
  path_then_require = function()
    package.path = OUT .. "/?.lua"
    local ok, v = pcall(require, "evil")
    return ok and v == "evil"
  end,
  traversal = function()
    for _, name in ipairs({"../outside/evil", "..outside.evil", "/" .. OUT .. "/evil"}) do
      local ok, v = pcall(require, name)
      if ok and v == "evil" then return true end
    end
    return false
  end,
  symlink = function() local ok, v = pcall(require, "link") return ok and v == "evil" end,
  searchpath = function() local ok, v = pcall(package.searchpath, "evil", OUT .. "/?.lua") return ok and v ~= nil end,
  loadfile = function() local ok, f = pcall(loadfile, OUT .. "/evil.lua") return ok and f ~= nil end,
  dofile = function() local ok, v = pcall(dofile, OUT .. "/evil.lua") return ok and v == "evil" end,
  io_open = function() local ok, f = pcall(io.open, OUT .. "/secret.txt") return ok and f ~= nil end,
  getupvalue = function()
    if not debug.getupvalue then return false end
    for i = 1, 40 do local _, v = debug.getupvalue(require, i) if reads(v) then return true end end
    return false
  end,
  getinfo = function()
    local info = debug.getinfo(require, "fu")
    return reads(info.func) and false  -- require itself: it must not read outside either
  end,
  dump = function()
    local ok, code = pcall(string.dump, require)
    if not ok then return false end
    local f = load(code, "=dump", "b")
    return f ~= nil
  end,
}
for name, attack in pairs(attacks) do
  local ok, got = pcall(attack)
  note(name, ok and got)
end
table.sort(stolen)
sim.setStringSignal("require", table.concat(stolen, " "))
-- the scene's own modules, and a subfolder's, still load (as Lua's require returns them)
local helper = require("helper")
local sub, where = require("sub.mod")
function ownModules() return {helper.value, sub.value}, {}, {where} end
"""


def test_require_keeps_its_searchers_out_of_a_scripts_reach(tmp_path):
    scene_dir, outside = tmp_path / "scene", tmp_path / "outside"
    scene_dir.mkdir()
    outside.mkdir()
    (outside / "secret.txt").write_text("secret")
    (outside / "evil.lua").write_text('return "evil"\n')
    (scene_dir / "helper.lua").write_text("return {value = 42}\n")
    (scene_dir / "sub").mkdir()
    (scene_dir / "sub" / "mod.lua").write_text("return {value = 7}\n")
    (scene_dir / "link.lua").symlink_to(outside / "evil.lua")
    (scene_dir / "sandbox.lua").write_text(REQUIRE_ATTACKS.replace("OUTSIDE", json.dumps(str(outside)), 1))
    (scene_dir / "scene.xml").write_text(SCENE)
    sim = Simulation(scene_dir / "scene.xml", realtime=False, allow_remote_code=True)
    try:
        sim.start()
        got = report(sim.signals.get_string("require"))
        assert len(got) == 13 and set(got.values()) == {"safe"}, got
        assert sim.scripts.call("Box", 1, "ownModules", [], [], [], b"") == [[42, 7], [], ["sub/mod.lua"], b""]
    finally:
        sim.close()
