"""Objects of a ``.ttt`` that keep their V-REP types (issue 50): V-REP's view cameras (type 3) and
old path objects (type 8) load as sites that answer ``sim.getObjectType``, the legacy object
lists and group data with their own types, the old path API (coppeliaSimLib ``CPathCont_old``:
Bezier points, virtual lengths, poses on the path) and the camera parameters."""

from __future__ import annotations

import math
import struct

import numpy as np
import pytest

import tttwriter as W
from simx_wire import constants as C
from simx_server.scene.ttt import reader

pytestmark = pytest.mark.renderers_on_demand  # no image is read from an in-process Simulation here


def f64(*values) -> bytes:
    return struct.pack(f"<{len(values)}d", *values)


def camera(handle: int, parent: int, name: str, pos=(0, 0, 1), ortho=1.5, angle=0.9, near=0.02, far=12.0,
           perspective=True) -> bytes:
    """A camera as ``CCamera::serialize`` writes it (4.5+ doubles)."""
    return W.rec("CMA", W.common(handle, parent, name, pos) + W.lst(
        W.rec("_p4", W.i32(-1) + f64(0.05)), W.rec("_p3", f64(ortho, angle)), W.rec("_cp", f64(near, far)),
        W.rec("Ca3", bytes([1 | (2 if perspective else 0)]))))


def path_point(pos, quat=(1, 0, 0, 0), count=1, factors=(0.5, 0.5), f32_form=False) -> bytes:
    """A ``CSimplePathPoint_old``: pose x y z qw qx qy qz, factors, Bezier point count, velocity."""
    if f32_form:
        return W.rec("Pat", W.lst(W.rec("At2", struct.pack("<7f2fif", *pos, *quat, *factors, count, 1.0))))
    return W.rec("Pat", W.lst(W.rec("_t2", struct.pack("<7d2did", *pos, *quat, *factors, count, 1.0)),
                              W.rec("_t3", f64(0.0)), W.rec("_t4", struct.pack("<H4d", 0, 0, 0, 0, 0))))


def old_path(handle: int, parent: int, name: str, points: bytes, attributes: int, pos=(0, 0, 0.5),
             position: float = 0.0) -> bytes:
    """An old path (``CPath_old::serialize``, its container ``CPathCont_old::serialize`` in Ntp)."""
    ntp = W.lst(points, W.rec("At2", W.i32(attributes)), W.rec("_m2", f64(position, 0.01, 0, 0)),
                W.rec("_v3", struct.pack("<di", 0.1 / (math.pi / 2), 5)), W.rec("_v9", f64(1.0)))
    return W.rec("PAT", W.common(handle, parent, name, pos) + W.lst(W.rec("Var", bytes([0])), W.rec("Ntp", ntp)))


CORNER = (path_point((0, 0, 0)) + path_point((1, 0, 0), count=15) + path_point((1, 1, 0)))
STRAIGHT = (path_point((0, 0, 0)) + path_point((1, 0, 0), f32_form=True) + path_point((1, 1, 0)))


def _scene() -> bytes:
    return W.ttt_file(
        W.cuboid_shape(1, -1, "Floor", (2, 2, 0.1), (0, 0, -0.05), dynamic=False) +
        camera(2, -1, "DefaultCamera") + camera(3, -1, "TopCamera", perspective=False) +
        old_path(4, -1, "Path", CORNER, 1 | 2 | 128) +
        old_path(5, -1, "Track", STRAIGHT, 1 | 2 | 128, position=0.5) +
        old_path(6, -1, "Oriented", STRAIGHT, 1 | 2 | 8 | 128) +
        W.dummy(7, -1, "Marker", (0.3, 0, 0)), serialization=24, program=40100)


@pytest.fixture
def sim(tmp_path, monkeypatch):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    from simx_server.scene.simulation import Simulation

    f = tmp_path / "kinds.ttt"
    f.write_bytes(_scene())
    s = Simulation(f, realtime=False)
    yield s
    s.close()


@pytest.fixture
def api(sim):
    from simx_server.api import script_sim

    return script_sim(sim.world, sim.world.resolve("Floor").handle, sim.signals, simulation=sim)


def test_reader_reads_cameras_and_old_paths(tmp_path):
    f = tmp_path / "kinds.ttt"
    f.write_bytes(_scene())
    s = reader.read(f)
    cam, top, path, track = s.objects[2].data, s.objects[3].data, s.objects[4].data, s.objects[5].data
    assert (cam.ortho_size, cam.view_angle, cam.near, cam.far, cam.perspective) == (1.5, 0.9, 0.02, 12.0, True)
    assert top.perspective is False
    assert len(path.points) == 3 and path.points[1][:3] == [1, 0, 0] and path.points[1][9] == 15
    assert path.attributes == 1 | 2 | 128 and path.length_method == 5
    assert track.position == 0.5 and track.points[1][:3] == [1, 0, 0]  # the float form of a point


def test_cameras_and_old_paths_keep_their_types(sim, api):
    w = sim.world
    cam, path, marker = (w.resolve(n).handle for n in ("DefaultCamera", "Path", "Marker"))
    assert api.getObjectType(cam) == C.sim_object_camera_type == 3
    assert api.getObjectType(path) == C.sim_object_path_type == 8
    assert api.getObjectType(marker) == C.sim_object_dummy_type
    from simx_server.commands import group_data, objects

    assert set(objects.get_objects(sim, [C.sim_object_camera_type])) == {cam, w.resolve("TopCamera").handle}
    assert len(objects.get_objects(sim, [C.sim_object_path_type])) == 3
    assert marker in objects.get_objects(sim, [C.sim_object_dummy_type])
    assert cam not in objects.get_objects(sim, [C.sim_object_dummy_type])
    handles, ints, _, _ = group_data.get_object_group_data(sim, [C.sim_handle_all, 1])  # 1: the types
    assert ints[handles.index(cam)] == 3 and ints[handles.index(path)] == 8
    assert api.getObjectPosition(cam, -1) == pytest.approx([0, 0, 1])
    api.setObjectPosition(path, -1, [0, 0, 0.6])  # a site: placed as a dummy is
    assert api.getObjectPosition(path, -1) == pytest.approx([0, 0, 0.6])


def test_old_path_api_follows_coppeliasims_bezier_points(api, sim):
    path = sim.world.resolve("Path").handle
    # the middle point's 15 Bezier points cut the corner from (0.75, 0) to (1, 0.25): length 2 - 0.5 + arc
    arc = api.getPathLength(path)
    assert 1.5 < arc < 2.0
    # symmetric: half the length is the curve's middle, 0.25 P0 + 0.5 P1 + 0.25 P2
    assert api.getPositionOnPath(path, 0.5) == pytest.approx([0.9375, 0.0625, 0.5])
    assert api.getPositionOnPath(path, 0.0) == pytest.approx([0, 0, 0.5])
    assert api.getPositionOnPath(path, 1.0) == pytest.approx([1, 1, 0.5])
    assert api.getPositionOnPath(path, 2.0) == pytest.approx([1, 1, 0.5])  # an open path clamps
    assert api.getPositionOnPath(path, -2.0) == pytest.approx([1, 0, 0.5])  # control point 1
    assert api.getOrientationOnPath(path, 0.3) == pytest.approx([0, 0, 0], abs=1e-9)
    track = sim.world.resolve("Track").handle
    assert api.getPathLength(track) == pytest.approx(2.0)  # no Bezier points: straight segments
    assert api.getPositionOnPath(track, 0.75) == pytest.approx([1, 0.5, 0.5])
    assert api.getPathPosition(track) == pytest.approx(0.5)  # the file's
    api.setPathPosition(track, 5.0)
    assert api.getPathPosition(track) == pytest.approx(2.0)  # clamped to the length
    with pytest.raises(Exception, match="not a path"):
        api.getPathLength(sim.world.resolve("Marker").handle)


def test_automatic_orientation_points_z_along_the_path(api, sim):
    """``_computeAutomaticOrientation``: z along the path; at the corner x is the turn's axis, y
    points outwards, z along the bisector; between points the poses interpolate."""
    oriented = sim.world.resolve("Oriented").handle

    def frame(relative):
        m = np.array(api.buildMatrix([0, 0, 0], api.getOrientationOnPath(oriented, relative))).reshape(3, 4)
        return m[:, :3]

    assert frame(0.0)[:, 2] == pytest.approx([1, 0, 0], abs=1e-6)
    corner = frame(0.5)
    assert corner[:, 2] == pytest.approx([math.sqrt(0.5), math.sqrt(0.5), 0], abs=1e-6)
    assert corner[:, 0] == pytest.approx([0, 0, 1], abs=1e-6)
    assert corner[:, 1] == pytest.approx([math.sqrt(0.5), -math.sqrt(0.5), 0], abs=1e-6)
    assert frame(0.25)[:, 2] == pytest.approx([math.cos(math.pi / 8), math.sin(math.pi / 8), 0], abs=1e-6)
    assert frame(1.0)[:, 2] == pytest.approx([0, 1, 0], abs=1e-6)


def test_created_old_path_takes_control_points(api, sim):
    path = api.createPath(-1, None, None, None)  # the old form: a number first
    assert api.getObjectType(path) == 8 and api.getObjectName(path).startswith("Path")
    with pytest.raises(Exception, match="empty"):
        api.getPositionOnPath(path, 0.5)
    pts = [0, 0, 0, 0, 0, 0, 1, 0, 1, 0.5, 0.5,
           2, 0, 0, 0, 0, 0, 1, 0, 1, 0.5, 0.5]
    assert api.insertPathCtrlPoints(path, 0, 0, 2, pts) == 1
    assert api.getPathLength(path) == pytest.approx(2.0)
    assert api.getPositionOnPath(path, 0.25) == pytest.approx([0.5, 0, 0])
    api.insertPathCtrlPoints(path, 0, 2, 1, [2, 2, 0, 0, 0, 0, 1, 0, 1, 0.5, 0.5])
    assert api.getPathLength(path) == pytest.approx(4.0)
    assert api.cutPathCtrlPoints(path, 0, 1) == 1
    assert api.getPathLength(path) == pytest.approx(2.0)
    assert api.getPositionOnPath(path, 0.0) == pytest.approx([2, 0, 0])
    api.cutPathCtrlPoints(path, -1, 0)  # every point
    assert api.getPathLength(path) == 0.0
    assert sim.world.resolve(api.getObjectName(path)).type == 8  # kept through the edit's rebuild


def test_camera_parameters(api, sim):
    cam, top = sim.world.resolve("DefaultCamera").handle, sim.world.resolve("TopCamera").handle
    get, c = api.getObjectFloatParam, api
    assert get(cam, c.camerafloatparam_perspective_angle) == pytest.approx(0.9)
    assert get(cam, c.camerafloatparam_ortho_size) == pytest.approx(1.5)
    assert get(cam, c.camerafloatparam_near_clipping) == pytest.approx(0.02)
    assert get(cam, c.camerafloatparam_far_clipping) == pytest.approx(12.0)
    assert api.getObjectInt32Param(cam, c.cameraintparam_perspective_operation) == 1
    assert api.getObjectInt32Param(top, c.cameraintparam_perspective_operation) == 0
    api.setObjectFloatParam(cam, c.camerafloatparam_perspective_angle, 3.0)  # limited to 135 degrees
    assert get(cam, c.camerafloatparam_perspective_angle) == pytest.approx(math.radians(135))
    api.setObjectFloatParam(cam, c.camerafloatparam_near_clipping, 0.5)  # coppeliaSimLib: unchanged
    assert get(cam, c.camerafloatparam_near_clipping) == pytest.approx(0.02)
    api.setObjectInt32Param(top, c.cameraintparam_perspective_operation, 1)
    assert api.getObjectInt32Param(top, c.cameraintparam_perspective_operation) == 1
    with pytest.raises(Exception):
        get(sim.world.resolve("Marker").handle, c.camerafloatparam_perspective_angle)


def test_4x_path_helpers_follow_coppeliasims_lua(api):
    """``sim-1.lua``'s helpers: a pose path's length is its positions', quaternions interpolate on
    the sphere, ``quadraticBezier`` rounds the corners, ``closed`` goes back to the start."""
    s = math.sqrt(0.5)
    poses = [0, 0, 0, 0, 0, 0, 1, 3, 0, 0, 0, 0, s, s]  # x y z qx qy qz qw: a quarter turn about z
    lengths, total = api.getPathLengths(poses, 7)
    assert lengths == pytest.approx([0, 3]) and total == pytest.approx(3)
    mid = api.getPathInterpolatedConfig(poses, lengths, 1.5, None, [0, 0, 0, 2, 2, 2, 2])
    assert mid == pytest.approx([1.5, 0, 0, 0, 0, math.sin(math.pi / 8), math.cos(math.pi / 8)])
    corner = [0, 0, 1, 0, 1, 1]
    lengths, _ = api.getPathLengths(corner, 2)
    assert api.getPathInterpolatedConfig(corner, lengths, 1.5) == pytest.approx([1, 0.5])
    bezier = {"type": "quadraticBezier", "strength": 1.0}
    assert api.getPathInterpolatedConfig(corner, lengths, 1.0, bezier) == pytest.approx([0.875, 0.125])
    assert api.getPathInterpolatedConfig(corner, lengths, 0.2, bezier) == pytest.approx([0.2, 0])  # open start
    loop = api.resamplePath(corner, lengths, 5, {"type": "linear", "closed": True})
    assert loop[-2:] == pytest.approx([0, 0], abs=1e-6)  # closed: back at the start
    assert len(loop) == 10 and loop[4:6] == pytest.approx([1, (2 + math.sqrt(2)) / 2 - 1], abs=1e-6)
    with pytest.raises(Exception, match="interpolation"):
        api.getPathInterpolatedConfig(corner, lengths, 1.0, {"type": "cubic"})


def test_4x_create_path_computes_path_data_as_its_model_script(api, sim):
    """``sim.createPath``'s new form: a dummy ``Path`` with ``PATHCTRLPTS`` and ``PATH`` (``subdiv``
    poses), as ``models/path_customization-2.lua`` computes them."""
    ctrl = [0, 0, 0, 0, 0, 0, 1, 1, 0, 0, 0, 0, 0, 1]
    p = api.createPath(ctrl, 0, 5, 1.0)
    assert api.getObjectType(p) == C.sim_object_dummy_type  # a 4.3+ path is a dummy
    assert api.unpackDoubleTable(api.readCustomBufferData(p, "PATHCTRLPTS")) == pytest.approx(ctrl)
    path = np.array(api.unpackDoubleTable(api.readCustomBufferData(p, "PATH"))).reshape(-1, 7)
    assert path[:, 0] == pytest.approx([0, 0.25, 0.5, 0.75, 1.0], abs=1e-6) and len(path) == 5
    oriented = api.createPath(ctrl, 16, 3, 1.0, 0, [0, 0, 1])  # x along the path, y up
    path = np.array(api.unpackDoubleTable(api.readCustomBufferData(oriented, "PATH"))).reshape(-1, 7)
    s = math.sqrt(0.5)
    assert path[1, 3:] == pytest.approx([s, 0, 0, s], abs=1e-6)  # a quarter turn about x: y up is z
    corner = api.createPath([0, 0, 0, 0, 0, 0, 1, 1, 0, 0, 0, 0, 0, 1, 1, 1, 0, 0, 0, 0, 1], 0, 50, 1.0)
    path = np.array(api.unpackDoubleTable(api.readCustomBufferData(corner, "PATH"))).reshape(-1, 7)
    assert np.min(np.linalg.norm(path[:, :3] - [1, 0, 0], axis=1)) > 0.05  # the corner is rounded
    with pytest.raises(Exception, match="coincide"):
        api.createPath([0, 0, 0, 0, 0, 0, 1] * 2, 0, 5)


PATH_SCRIPT = """
function sysCall_init()
  local p = sim.getObjectHandle('Path')
  local xyz = sim.getPositionOnPath(p, 0.5)
  sim.setFloatSignal('mid_x', xyz[1])
  sim.setFloatSignal('length', sim.getPathLength(p))
  sim.setInt32Signal('camera_type', sim.getObjectType(sim.getObjectHandle('DefaultCamera')))
end
"""


def test_legacy_clients_and_scripts_see_the_kinds(tmp_path, monkeypatch):
    """Over a real server: ``simxGetObjects`` by type, ``simxGetObjectGroupData``'s names and
    types, a camera's float parameter, and a 4.1 child script's old path calls."""
    import vrep

    try:
        from conftest import ServerProcess
    except ImportError:
        from tests.conftest import ServerProcess

    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    f = tmp_path / "kinds.ttt"
    f.write_bytes(W.ttt_file(
        W.cuboid_shape(1, -1, "Floor", (2, 2, 0.1), (0, 0, -0.05), dynamic=False) +
        camera(2, -1, "DefaultCamera") + camera(3, -1, "TopCamera", perspective=False) +
        old_path(4, -1, "Path", CORNER, 1 | 2 | 128) + W.script(100, 1, PATH_SCRIPT),
        serialization=24, program=40100))
    B = vrep.simx_opmode_blocking
    srv = ServerProcess(str(f), renderers="on-demand")
    try:
        cid = vrep.simxStart("127.0.0.1", srv.port, True, True, 5000, 5)
        assert cid >= 0
        rc, cams = vrep.simxGetObjects(cid, vrep.sim_object_camera_type, B)
        assert rc == 0 and len(cams) == 2
        rc, paths = vrep.simxGetObjects(cid, vrep.sim_object_path_type, B)
        assert rc == 0 and len(paths) == 1
        rc, handles, _, _, names = vrep.simxGetObjectGroupData(cid, vrep.sim_object_path_type, 0, B)
        assert rc == 0 and names == ["Path"]
        rc, handles, types, _, _ = vrep.simxGetObjectGroupData(cid, vrep.sim_handle_all, 1, B)
        assert rc == 0 and types[handles.index(cams[0])] == 3 and types[handles.index(paths[0])] == 8
        rc, cam = vrep.simxGetObjectHandle(cid, "DefaultCamera", B)
        assert vrep.simxGetObjectFloatParameter(cid, cam, vrep.sim_camerafloatparam_perspective_angle, B) == \
            (0, pytest.approx(0.9))
        assert vrep.simxSynchronous(cid, True) == 0
        assert vrep.simxStartSimulation(cid, B) == 0
        assert vrep.simxSynchronousTrigger(cid) == 0  # one pass: the child script's init has run
        rc, x = vrep.simxGetFloatSignal(cid, "mid_x", B)
        assert rc == 0 and x == pytest.approx(0.9375, abs=1e-5)
        assert vrep.simxGetIntegerSignal(cid, "camera_type", B) == (0, 3)
        vrep.simxStopSimulation(cid, B)
        vrep.simxFinish(cid)
    finally:
        srv.stop()


def test_a_stop_restores_path_positions_and_camera_optics(api, sim):
    """``CPathCont_old::simulationEnded`` / ``CCamera::simulationEnded``: what changed while running
    is back at the stop; what changed while stopped stays."""
    track, cam = sim.world.resolve("Track").handle, sim.world.resolve("DefaultCamera").handle
    angle = api.camerafloatparam_perspective_angle
    sim.start()
    api.setPathPosition(track, 1.5)
    api.setObjectFloatParam(cam, angle, 1.2)
    sim.step()
    assert api.getPathPosition(track) == pytest.approx(1.5)
    sim.stop()
    assert api.getPathPosition(track) == pytest.approx(0.5)  # the file's
    assert api.getObjectFloatParam(cam, angle) == pytest.approx(0.9)
    api.setPathPosition(track, 1.0)  # stopped: kept
    sim.start()
    sim.stop()
    assert api.getPathPosition(track) == pytest.approx(1.0)


def test_a_copied_path_keeps_its_current_points(api, sim):
    path = api.createPath(-1, None, None, None)
    api.insertPathCtrlPoints(path, 0, 0, 2, [0, 0, 0, 0, 0, 0, 1, 0, 1, 0.5, 0.5, 3, 0, 0, 0, 0, 0, 1, 0, 1, 0.5, 0.5])
    cam = sim.world.resolve("DefaultCamera").handle
    api.setObjectFloatParam(cam, api.camerafloatparam_ortho_size, 4.0)
    path2, cam2 = api.copyPasteObjects([path, cam])
    assert api.getObjectType(path2) == 8 and api.getPathLength(path2) == pytest.approx(3.0)
    assert api.getObjectType(cam2) == 3
    assert api.getObjectFloatParam(cam2, api.camerafloatparam_ortho_size) == pytest.approx(4.0)
    api.cutPathCtrlPoints(path, -1, 0)  # the original only
    assert api.getPathLength(path2) == pytest.approx(3.0)


def test_closest_position_on_an_old_path(api, sim):
    track = sim.world.resolve("Track").handle  # (0,0) -> (1,0) -> (1,1), length 2, in its frame
    assert api.getClosestPositionOnPath(track, [0.5, -0.3, 0]) == pytest.approx(0.25)
    assert api.getClosestPositionOnPath(track, [1.4, 0.6, 0]) == pytest.approx(0.8)
    assert api.getClosestPositionOnPath(track, [-1, -1, 0]) == pytest.approx(0.0)
