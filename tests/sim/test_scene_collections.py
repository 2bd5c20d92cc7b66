"""Collections a scene declares (``simx:collection:NAME``, what ``simx-convert`` writes from a
``.ttt`` file's collections): V-REP's element types in order, names and handles, the facade's
3.x / deprecated calls, and collections as entities of ``checkCollision`` / ``checkDistance``
(simx_server/sim/scene_collections.py)."""

from __future__ import annotations

import logging

import pytest

from simx_wire.protocol import UnknownObjectError
from simx_server.scene.simulation import Simulation
from simx_server.api import script_sim
from simx_server.sim import scene_collections

pytestmark = pytest.mark.renderers_on_demand  # no image is read from an in-process Simulation here

SCENE = """<mujoco model="collections">
  <option gravity="0 0 0"/>
  <worldbody>
    <geom name="Floor" type="plane" size="2 2 0.1"/>
    <body name="Base" pos="0 0 0.1"><geom type="box" size="0.1 0.1 0.1"/>
      <body name="Link" pos="0 0 0.3"><joint name="Hinge" type="hinge" axis="0 1 0"/>
        <geom type="box" size="0.03 0.03 0.15"/><site name="Tip" pos="0 0 0.15"/>
      </body>
    </body>
    <body name="Cube" pos="0.5 0 0.05"><freejoint/><geom type="box" size="0.05 0.05 0.05"/></body>
    <body name="Ball" pos="0.5 0 0.5"><freejoint/><geom type="sphere" size="0.05"/></body>
  </worldbody>
  <custom>
    <text name="simx:collection:Arm" data="items=+tree:Base,-single:Tip"/>
    <text name="simx:collection:NotCube" data="items=+all,-single:Cube"/>
    <text name="simx:collection:TipChain" data="items=+chain_without_tip:Tip"/>
    <text name="simx:collection:Balls" data="items=+single:Ball"/>
    <text name="simx:collection:Broken" data="items=+single:NoSuchThing"/>
  </custom>
</mujoco>
"""


@pytest.fixture
def sim(tmp_path, caplog):
    path = tmp_path / "scene.xml"
    path.write_text(SCENE)
    with caplog.at_level(logging.ERROR, logger="simx.scene"):
        s = Simulation(path, realtime=False)
    yield s
    s.close()


def names(sim, members):
    return sorted(sim.world.objects[h].name for h in members)


def test_elements_apply_in_order_and_handles_follow_the_names(sim, caplog):
    c = scene_collections.of(sim.world)
    assert c.names == {"Arm": 2_000_000, "Balls": 2_000_001, "NotCube": 2_000_002, "TipChain": 2_000_003}
    assert names(sim, c.present(c.handle("Arm"))) == ["Base", "Hinge", "Link"]
    assert names(sim, c.present(c.handle("TipChain"))) == ["Base", "Hinge", "Link"]
    every = set(sim.world.objects) - {sim.world.resolve("Cube").handle}
    assert set(c.present(c.handle("NotCube"))) == every
    # a declaration naming no object is logged with its element, and the rest of the scene loads
    assert any("collection 'Broken'" in r.getMessage() and "NoSuchThing" in r.getMessage() for r in caplog.get_records("setup"))
    with pytest.raises(UnknownObjectError, match="collection 'Broken' does not exist"):
        c.handle("Broken")


def test_facade_names_objects_and_collision_with_collections(sim):
    sim.start()
    sim.step()
    api = script_sim(sim.world, sim.world.resolve("Base").handle, sim.signals, simulation=sim)
    arm, balls = api.getCollectionHandle("Arm"), api.getCollectionHandle("Balls")
    assert api.getCollectionName(arm) == "Arm"
    assert names(sim, api.getCollectionObjects(arm)) == ["Base", "Hinge", "Link"]
    cube = api.getObject("/Cube")
    # the arm rests on the floor (its base does) but is 0.3 m from the cube
    result, pair = api.checkCollision(arm, api.handle_all)
    assert result == 1 and pair[0] in (api.getObject("/Base"), api.getObject("/Link"))
    assert api.checkCollision(arm, cube) == (0, [-1, -1])
    result, data, pair = api.checkDistance(balls, cube)
    assert result == 1 and data[6] == pytest.approx(0.35, abs=1e-6)
    assert pair == [api.getObject("/Ball"), cube]
    # a run-time collection continues the numbering and works the same way
    mine = api.createCollection()
    assert mine == 2_000_004 and api.getCollectionName(mine) == ""
    api.addItemToCollection(mine, api.handle_single, cube, 0)
    assert api.checkCollision(mine, api.handle_all)[0] == 1  # the cube stands on the floor
    api.destroyCollection(mine)
    with pytest.raises(UnknownObjectError):
        api.getCollectionObjects(mine)


def test_an_entity_against_itself(sim):
    """coppeliaSimLib 4.1 ``CCollisionRoutine::doEntitiesCollide``: a shape never collides with
    itself; a collection against itself tests its shapes against one another (RLBench's spawn
    boundaries ask an object against itself)."""
    sim.start()
    api = script_sim(sim.world, sim.world.resolve("Base").handle, sim.signals, simulation=sim)
    cube, ball = api.getObject("/Cube"), api.getObject("/Ball")
    pair = api.createCollection()
    api.addItemToCollection(pair, api.handle_single, cube, 0)
    api.addItemToCollection(pair, api.handle_single, ball, 0)
    assert api.checkCollision(cube, cube) == (0, [-1, -1])
    assert api.checkCollision(pair, pair)[0] == 0  # the ball floats 0.35 m above the cube
    api.setObjectPosition(ball, -1, [0.5, 0, 0.14])  # into the cube's top face
    assert api.checkCollision(ball, ball)[0] == 0
    result, objects = api.checkCollision(pair, pair)
    assert result == 1 and sorted(objects) == sorted([cube, ball])
