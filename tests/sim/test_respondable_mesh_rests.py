"""A mesh shape made at run time, then made dynamic and respondable (RLBench's procedural
objects: ``Shape.import_mesh``, ``set_dynamic``, ``set_respondable``), rests where it lands, as
on CoppeliaSim: its mesh gets its convex hull when it becomes respondable, so MuJoCo's collider
finds the face's contact points, not one vertex at a time (without the hull the block rocked
from one support point to the next and walked across the floor)."""

from __future__ import annotations

import numpy as np
import pytest

from simx_server.api import client_context
from simx_server.scene.simulation import Simulation

pytestmark = pytest.mark.renderers_on_demand  # no image is read

SCENE = """<mujoco model="rest">
  <option timestep="0.002"/>
  <worldbody><body name="floor" pos="0 0 -0.02"><geom type="box" size="0.5 0.5 0.02"/></body></worldbody>
</mujoco>
"""


def block() -> tuple[np.ndarray, np.ndarray]:
    """A 6 x 4 x 3 cm block of slightly uneven corners: 8 vertices, 12 triangles."""
    v = np.array([[x, y, z] for z in (0.0, 0.03) for y in (0.0, 0.04) for x in (0.0, 0.06)])
    v[4:] += np.random.default_rng(3).uniform(-0.002, 0.002, (4, 3))  # a top that is not a box's
    f = [[0, 2, 1], [1, 2, 3], [4, 5, 6], [5, 7, 6], [0, 1, 4], [1, 5, 4],
         [2, 6, 3], [3, 6, 7], [0, 4, 2], [2, 4, 6], [1, 3, 5], [3, 7, 5]]
    return v, np.array(f)


def test_a_run_time_mesh_made_respondable_rests_where_it_lands(tmp_path):
    path = tmp_path / "rest.xml"
    path.write_text(SCENE)
    simulation = Simulation(path, realtime=False)
    try:
        api = client_context(simulation, "test").sim
        v, f = block()
        shape = api.createShape(0, 0.0, v.ravel().tolist(), f.ravel().tolist(), [], [], None, [])
        api.setObjectPosition(shape, -1, [0.0, 0.0, 0.0155])
        assert api.getObjectInt32Param(shape, api.shapeintparam_respondable) == 0
        api.setObjectInt32Param(shape, api.shapeintparam_static, 0)
        api.setObjectInt32Param(shape, api.shapeintparam_respondable, 1)
        world = simulation.world
        m = world.model
        geoms = np.flatnonzero(m.geom_bodyid == world.objects[shape].mj_id)
        assert (m.mesh_graphadr[m.geom_dataid[geoms]] >= 0).all()  # the hull MuJoCo collides
        simulation.start()
        for _ in range(20):  # 1 s: it settles
            simulation.step()
        settled = np.array(api.getObjectPosition(shape, -1))
        for _ in range(40):  # 2 s at rest
            simulation.step()
        drift = np.linalg.norm(np.array(api.getObjectPosition(shape, -1)) - settled)
        assert drift < 2e-4, f"the block moved {drift * 1000:.2f} mm at rest"
        touching = [c for c in world.data.contact[:world.data.ncon] if world.objects[shape].mj_id in
                    (m.geom_bodyid[c.geom1], m.geom_bodyid[c.geom2])]
        assert len(touching) >= 3  # a face on the floor, not a vertex
    finally:
        simulation.close()
