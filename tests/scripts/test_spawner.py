"""A part spawner of CoppeliaSim 4.x's factory cells, on the project's own small scene, in-process
(no wall clock, no network): a non-threaded script starts a coroutine that copies a static part
template, hangs the copy under the (static) spawner, makes it dynamic and waits a few seconds
(``sim.wait`` inside a coroutine of a non-threaded script, as CoppeliaSim 4.x's ``sim.wait``
yields from any coroutine); each copy falls to the floor as a free body (V-REP simulates a
dynamic shape under a static parent freely).
"""

from __future__ import annotations

import logging

import numpy as np
import pytest

from simx_server.scene.simulation import Simulation

pytestmark = pytest.mark.renderers_on_demand  # no image is read from an in-process Simulation here

SCENE = """<mujoco model="spawner">
  <option timestep="0.005"/>
  <worldbody>
    <geom name="Floor" type="plane" size="3 3 0.1"/>
    <body name="Spawner" pos="0 0 0.6">
      <geom type="box" size="0.05 0.05 0.05" contype="0" conaffinity="0"/>
    </body>
    <body name="Part" pos="1 1 0.5"><geom type="sphere" size="0.03" mass="0.1"/></body>
  </worldbody>
  <custom><text name="simx:Spawner" data="child_script=spawner.lua"/></custom>
</mujoco>
"""
# A 4.x non-threaded script with CoppeliaSim's coroutine pattern (its default child script's
# coroutineMain): one part every two seconds of simulation time.
SPAWNER_LUA = """function sysCall_init()
    template=sim.getObject('/Part')
    spawner=sim.getObject('.')
    parts={}
    waited={}
    corout=coroutine.create(coroutineMain)
end
function sysCall_actuation()
    if coroutine.status(corout)~='dead' then
        local ok,errorMsg=coroutine.resume(corout)
        if errorMsg then error(debug.traceback(corout,errorMsg),2) end
    end
end
function coroutineMain()
    while true do
        local copy=sim.copyPasteObjects({template},0)[1]
        sim.setObjectParent(copy,spawner,true)
        sim.setObjectPosition(copy,spawner,{0.1*#parts,0,-0.1})  -- side by side
        sim.setObjectInt32Param(copy,sim.shapeintparam_static,0)
        sim.resetDynamicObject(copy)
        parts[#parts+1]=copy
        waited[#waited+1]=sim.wait(2)
    end
end
function report()
    return parts,waited,{},''
end
function waitHere()  -- called on the script's main line: nothing to yield, the wait would never end
    local ok,err=pcall(sim.wait,1)
    return {ok and 1 or 0},{},{tostring(err)},''
end
"""


def test_a_coroutine_spawner_drops_a_part_every_two_seconds(tmp_path, caplog):
    (tmp_path / "spawner.lua").write_text(SPAWNER_LUA)
    (tmp_path / "scene.xml").write_text(SCENE)
    sim = Simulation(tmp_path / "scene.xml", realtime=False)
    world = sim.world
    spawner = world.resolve("Spawner").handle
    try:
        with caplog.at_level(logging.WARNING, "simx"):
            sim.start()
            assert world.dt == pytest.approx(0.05)
            for _ in range(100):  # 5 s: parts made at 0, 2 and 4 s
                sim.step()
            parts, waited = sim.scripts.call("Spawner", 1, "report", [], [], [], b"")[:2]
            refused = sim.scripts.call("Spawner", 1, "waitHere", [], [], [], b"")
        assert not [r for r in caplog.records if r.levelno >= logging.ERROR], [r.getMessage() for r in caplog.records]
        assert len(parts) == 3 and len(set(parts)) == 3
        assert refused[0] == [0] and "coroutine" in refused[2][0]
        assert waited == [pytest.approx(0, abs=1e-9)] * 2  # sim.wait: the time past dt (0: steps of 50 ms)
        for i, part in enumerate(parts):
            assert world.get(part).parent == spawner  # V-REP's tree: under the spawner
            x, y, z = world.position(part, -1)
            assert (x, y) == pytest.approx((0.1 * i, 0), abs=0.02)
            if i < 2:  # fell 0.47 m onto the floor, and rests there
                assert z == pytest.approx(0.03, abs=0.003)
        assert world.position(parts[2], -1)[2] < 0.5 - 0.01  # made at 4 s: falling
        assert np.allclose(world.position(world.resolve("Part").handle, -1), [1, 1, 0.5])  # the template stays
    finally:
        sim.stop()
        sim.close()
