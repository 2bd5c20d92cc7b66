"""CoppeliaSim 4.x's point clouds and octrees kept as data (issue 32), in-process on a Simulation
and through a Lua child script: points and voxels in the object's frame, tolerances, objects
inserted and subtracted as their MuJoCo geometry."""

from __future__ import annotations

import numpy as np
import pytest

from simx_client.protocol import ArgumentError, RemoteError
from simx_server.scene.simulation import Simulation
import facade_fixtures

pytestmark = pytest.mark.renderers_on_demand  # no image is read from an in-process Simulation here

sim, api = facade_fixtures.sim, facade_fixtures.api  # the shared fixtures


def pts(flat):
    return np.array(flat).reshape(-1, 3)


def test_point_cloud_points_live_in_its_frame(api):
    pc = api.createPointCloud(0.02, 20, 0, 2)
    assert api.getPointCloudOptions(pc) == (0.02, 20, 0, 2)
    api.setObjectPosition(pc, -1, [1, 0, 0])
    assert api.insertPointsIntoPointCloud(pc, 0, [1, 0, 0, 1.5, 0, 0]) == 2   # world coordinates
    assert api.insertPointsIntoPointCloud(pc, 1, [0, 0, 1]) == 3              # bit 0: relative
    assert pts(api.getPointCloudPoints(pc)) == pytest.approx(pts([0, 0, 0, 0.5, 0, 0, 0, 0, 1]))
    # a duplicate tolerance leaves out points near one already there or inserted before
    assert api.insertPointsIntoPointCloud(pc, 1, [0.01, 0, 0, 2, 0, 0, 2.01, 0, 0], None, 0.05) == 4
    assert api.removePointsFromPointCloud(pc, 1, [0.5, 0, 0.02], 0.05) == 3
    assert api.intersectPointsWithPointCloud(pc, 1, [0, 0, 0, 2, 0, 0], 0.01) == 2
    assert api.removePointsFromPointCloud(pc, 0, None, 0) == 0
    with pytest.raises(ArgumentError, match="x, y, z"):
        api.insertPointsIntoPointCloud(pc, 0, [1, 2])
    with pytest.raises(RemoteError, match="not a point cloud"):
        api.getPointCloudPoints(api.getObject("/blockA"))


def test_shapes_go_into_and_out_of_a_point_cloud(api):
    box = api.getObject("/blockA")  # a 0.2 m cube at (0, 2, 0.5)
    pc = api.createPointCloud(0.05, 20, 0, 2)
    n = api.insertObjectIntoPointCloud(pc, box, 0, 0.02)
    p = pts(api.getPointCloudPoints(pc)) - [0, 2, 0.5]
    assert n == len(p) > 100
    assert np.abs(p).max(axis=1) == pytest.approx(np.full(len(p), 0.1), abs=2e-3)  # on the cube's faces
    # points inside the cube and one outside: subtracting the cube leaves the outside one
    api.removePointsFromPointCloud(pc, 0, None, 0)
    api.insertPointsIntoPointCloud(pc, 0, [0, 2, 0.5, 0.05, 2.05, 0.45, 0.5, 2, 0.5])
    assert api.subtractObjectFromPointCloud(pc, box, 0, 0.0) == 1
    assert api.getPointCloudPoints(pc) == pytest.approx([0.5, 2, 0.5])


def test_octree_voxels_tags_and_occupancy(api):
    oc = api.createOctree(0.1, 0, 1)
    assert api.insertVoxelsIntoOctree(oc, 0, [0.05, 0.05, 0.05, 0.07, 0.02, 0.01, 0.25, 0, 0], None, 7) == 2
    assert pts(api.getOctreeVoxels(oc)) == pytest.approx(pts([0.05, 0.05, 0.05, 0.25, 0.05, 0.05]))
    res, tag, low, high = api.checkOctreePointOccupancy(oc, 0, [0.01, 0.09, 0.09])
    assert (res, tag) == (1, 7)
    assert api.checkOctreePointOccupancy(oc, 0, [0.01, 0.01, 0.01, 0.5, 0.5, 0.5])[0] == 0  # not all
    assert api.checkOctreePointOccupancy(oc, 2, [0.5, 0.5, 0.5, 0.01, 0.01, 0.01])[0] == 1  # bit 1: any
    assert api.removeVoxelsFromOctree(oc, 0, [0.21, 0.01, 0.01]) == 1
    # a cube voxelised on its surface; subtracting it frees them again
    box = api.getObject("/blockA")
    api.removeVoxelsFromOctree(oc, 0, None)
    n = api.insertObjectIntoOctree(oc, box, 0, None, 3)
    centres = pts(api.getOctreeVoxels(oc))
    assert n == len(centres) > 8
    assert (np.abs(centres - [0, 2, 0.5]).max(axis=1) <= 0.1 + 0.1).all()
    assert api.subtractObjectFromOctree(oc, box, 0) == 0


LUA = """
function cloud(ints, floats, strings, buf)
    local oc = sim.createOctree(0.1, 0, 1)
    sim.insertVoxelsIntoOctree(oc, 0, {0.05, 0.05, 0.05, 0.35, 0.05, 0.05})
    local pc = sim.createPointCloud(0.1, 10, 0, 1)
    local n = sim.insertObjectIntoPointCloud(pc, oc, 0, 0.1)
    return {n}, sim.getPointCloudPoints(pc)
end
function poses(ints, floats, strings, buf)
    local p = sim.multiplyPoses({1, 0, 0, 0, 0, 0, 1}, {0, 2, 0, 0, 0, 0, 1})
    local m = sim.poseToMatrix(p)
    return {}, {p[1], p[2], m[4], m[8]}
end
"""


def test_lua_script_builds_a_cloud_from_an_octree(tmp_path):
    (tmp_path / "cloud.lua").write_text(LUA)
    scene = tmp_path / "cloud.xml"
    scene.write_text("""<mujoco><worldbody><site name="Cloud" size="0.01"/></worldbody>
<custom><text name="simx:Cloud" data="child_script=cloud.lua"/></custom></mujoco>""")
    sim = Simulation(scene, realtime=False)
    sim.start()
    try:
        ints, floats, _, _ = sim.scripts.call("Cloud", 1, "cloud", [], [], [], b"")
        assert ints == [2]
        assert floats == pytest.approx([0.05, 0.05, 0.05, 0.35, 0.05, 0.05])
        _, floats, _, _ = sim.scripts.call("Cloud", 1, "poses", [], [], [], b"")
        assert floats == pytest.approx([1, 2, 1, 2])  # pose arithmetic in scripts too
    finally:
        sim.stop()
        sim.close()
